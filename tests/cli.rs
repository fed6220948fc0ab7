//! Tier 4: the real `tetsim` binary, spawned in a temp dir: outputs, exit codes, messages. Bad
//! input gives exit ≠ 0 and an error naming the file and the line, element or node.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

#[path = "cli/analyses.rs"]
mod analyses;
#[path = "common/beam24.rs"]
mod beam24;
#[path = "cli/checkpoints.rs"]
mod checkpoints;
#[path = "cli/contact.rs"]
mod contact;
#[path = "cli/contact_trust.rs"]
mod contact_trust;
#[path = "cli/modes.rs"]
mod modes;
#[path = "cli/pictures.rs"]
mod pictures;
#[path = "cli/quadratic.rs"]
mod quadratic;
#[path = "cli/render_surface.rs"]
mod render_surface;
#[path = "cli/resume.rs"]
mod resume;
#[path = "cli/tetrahedralize.rs"]
mod tetrahedralize;
#[path = "cli/trust.rs"]
mod trust;

fn fixtures() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures")
}

/// Copy `names` from the fixtures into a fresh temp dir (so nothing is written in the repo).
fn staged(names: &[&str]) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    for name in names {
        let target = dir.path().join(Path::new(name).file_name().unwrap());
        std::fs::copy(fixtures().join(name), target).unwrap();
    }
    dir
}

fn tetsim(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_tetsim"))
        .args(args)
        .current_dir(dir)
        .env("RUST_LOG", "warn")
        .output()
        .expect("the tetsim binary runs")
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// `mesh check` on a broken fixture fails, and stderr contains every expected piece.
fn check_fails(files: &[&str], arg: &str, expected: &[&str]) {
    let dir = staged(files);
    let out = tetsim(dir.path(), &["mesh", "check", arg]);
    assert!(!out.status.success(), "{arg} was accepted");
    assert_eq!(out.status.code(), Some(1));
    let err = stderr(&out);
    for piece in expected {
        assert!(err.contains(piece), "{arg}: `{piece}` not in: {err}");
    }
    assert!(!err.contains("panicked"), "{err}");
}

#[test]
fn truncated_msh_fails_with_file_and_line() {
    check_fails(
        &["bad/truncated_v41.msh"],
        "truncated_v41.msh",
        &["error: truncated_v41.msh:987:", "truncated"],
    );
}

#[test]
fn missing_node_fails_naming_element_and_node() {
    check_fails(
        &["bad/missing_node.node", "bad/missing_node.ele"],
        "missing_node.node",
        &["missing_node.ele: element 2 refers to node 99"],
    );
}

#[test]
fn degenerate_tet_fails_naming_the_element_unless_forced() {
    let files = ["bad/degenerate.node", "bad/degenerate.ele"];
    check_fails(
        &files,
        "degenerate.ele",
        &["degenerate.ele: degenerate element", ": 2", "--force"],
    );
    let dir = staged(&files);
    let out = tetsim(dir.path(), &["mesh", "check", "--force", "degenerate.ele"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let report = String::from_utf8_lossy(&out.stdout);
    assert!(report.contains("error: degenerate element"), "{report}");
}

#[test]
fn nan_coordinate_fails_naming_the_node() {
    check_fails(
        &["bad/nan_coordinate.node", "bad/nan_coordinate.ele"],
        "nan_coordinate.ele",
        &["nan_coordinate.node: node 2 has a non-finite"],
    );
}

#[test]
fn not_a_mesh_fails_at_line_one() {
    check_fails(
        &["bad/not_a_mesh.msh"],
        "not_a_mesh.msh",
        &["not_a_mesh.msh:1: not a Gmsh mesh"],
    );
}

#[test]
fn triangles_only_fails_for_lack_of_tets() {
    check_fails(
        &["bad/triangles_only_v22.msh"],
        "triangles_only_v22.msh",
        &["triangles_only_v22.msh: the mesh has no tetrahedra"],
    );
}

#[test]
fn missing_file_fails_naming_it() {
    check_fails(&[], "nowhere.msh", &["nowhere.msh"]);
}

#[test]
fn check_reports_a_good_mesh_and_its_groups() {
    let dir = staged(&["beam_v41_binary.msh"]);
    let out = tetsim(dir.path(), &["mesh", "check", "beam_v41_binary.msh"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let report = String::from_utf8_lossy(&out.stdout);
    for piece in [
        "Gmsh 4.1 binary",
        "458 vertices, 1471 tets",
        "group \"clamp\"",
        "Euler characteristic 2",
        "suggested dt",
        "verdict: OK",
    ] {
        assert!(report.contains(piece), "`{piece}` not in: {report}");
    }
}

#[test]
fn convert_goes_through_every_format_and_back() {
    let dir = staged(&["beam_v41.msh"]);
    let mut previous = "beam_v41.msh".to_string();
    for (target, extra) in [
        ("a.vtu", None),
        ("b.vtk", Some("--ascii")),
        ("c.node", None),
        ("d.mesh", None),
        ("e.msh", Some("--binary")),
        ("f.msh", Some("--msh22")),
    ] {
        let mut args = vec!["mesh", "convert", &previous, target];
        args.extend(extra);
        let out = tetsim(dir.path(), &args);
        assert!(out.status.success(), "{target}: {}", stderr(&out));
        let stdout = String::from_utf8_lossy(&out.stdout);
        assert!(
            stdout.contains("458 vertices, 1471 tets"),
            "{target}: {stdout}"
        );
        previous = target.to_string();
    }
    let out = tetsim(dir.path(), &["mesh", "convert", "f.msh", "surface.obj"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let obj = std::fs::read_to_string(dir.path().join("surface.obj")).unwrap();
    assert_eq!(obj.lines().filter(|l| l.starts_with("f ")).count(), 762);
}

#[test]
fn convert_to_an_unknown_format_fails() {
    let dir = staged(&["beam_v41.msh"]);
    let out = tetsim(dir.path(), &["mesh", "convert", "beam_v41.msh", "beam.stl"]);
    assert!(!out.status.success());
    assert!(
        stderr(&out).contains("unknown mesh format `.stl`"),
        "{}",
        stderr(&out)
    );
}

// ---- tetsim run ----

#[test]
fn run_default_scene_writes_every_file() {
    let dir = tempfile::tempdir().unwrap();
    let out = tetsim(dir.path(), &["run", "--frames", "3"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let out_dir = dir.path().join("out");
    for frame in 0..=3 {
        let obj = std::fs::read_to_string(out_dir.join(format!("surface_{frame:04}.obj"))).unwrap();
        assert!(
            !obj.contains("NaN") && !obj.contains("inf"),
            "surface {frame} has non-finite values"
        );
        // Read the frame back with the library's own VTU reader: points and every array finite.
        let vtu =
            tetsim::io::read_vtu_frame(&out_dir.join(format!("frame_{frame:04}.vtu"))).unwrap();
        assert!(
            vtu.points.len() > 100 && vtu.points.iter().all(|p| p.iter().all(|c| c.is_finite()))
        );
        for name in ["displacement", "velocity"] {
            let field = vtu
                .point_field(name)
                .unwrap_or_else(|| panic!("frame {frame} lacks {name}"));
            assert!(finite(field), "frame {frame}: {name} not finite");
        }
        for name in ["J", "strain_energy_density", "von_mises"] {
            let field = vtu
                .cell_field(name)
                .unwrap_or_else(|| panic!("frame {frame} lacks {name}"));
            assert!(finite(field), "frame {frame}: {name} not finite");
        }
    }
    let pvd = std::fs::read_to_string(out_dir.join("frames.pvd")).unwrap();
    assert_eq!(pvd.matches("<DataSet").count(), 4);
    assert!(pvd.contains("timestep=\"0.1\""), "{pvd}");
    let csv = std::fs::read_to_string(out_dir.join("steps.csv")).unwrap();
    let mut lines = csv.lines();
    let header = lines.next().unwrap();
    assert!(
        header.starts_with("frame,time,newton_iterations,cg_iterations,residual,converged,elastic_energy,kinetic_energy,min_J,inverted_elements,wall_seconds"),
        "{header}"
    );
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    assert_eq!(rows.len(), 4);
    for row in &rows {
        assert_eq!(row.len(), header.split(',').count());
        for (i, cell) in row.iter().enumerate() {
            if i != 5 {
                let value: f64 = cell
                    .parse()
                    .unwrap_or_else(|_| panic!("not a number: {cell}"));
                assert!(value.is_finite());
            }
        }
        assert_eq!(row[5], "true");
    }
    assert!(
        rows[3][6].parse::<f64>().unwrap() > 0.0,
        "the beam should store elastic energy"
    );
    for picture in [
        "preview.png",
        "animation.gif",
        "steps_newton.png",
        "steps_cg.png",
        "steps_residual.png",
        "steps_energy.png",
    ] {
        let bytes =
            std::fs::read(out_dir.join(picture)).unwrap_or_else(|e| panic!("{picture}: {e}"));
        assert!(bytes.len() > 1000, "{picture} is empty");
    }
    // Re-render the saved run from its frames, coloured by J, cut open.
    let out = tetsim(
        dir.path(),
        &[
            "render", "out", "--field", "J", "--cut", "z", "--out", "again", "--frames", "1..3",
        ],
    );
    assert!(out.status.success(), "{}", stderr(&out));
    let gif = std::fs::read(dir.path().join("again/animation.gif")).unwrap();
    assert_eq!(&gif[..6], b"GIF89a");
    let out = tetsim(dir.path(), &["render", "out", "--frames", "2..9"]);
    assert!(
        !out.status.success() && stderr(&out).contains("outside the run"),
        "{}",
        stderr(&out)
    );
    // Nothing left behind half-written.
    assert!(
        std::fs::read_dir(&out_dir).unwrap().all(|e| !e
            .unwrap()
            .file_name()
            .to_string_lossy()
            .ends_with(".tmp"))
    );
}

fn finite(field: &tetsim::io::FieldData) -> bool {
    match field {
        tetsim::io::FieldData::Scalar(v) => v.iter().all(|x| x.is_finite()),
        tetsim::io::FieldData::Vector(v) => v.iter().all(|p| p.iter().all(|c| c.is_finite())),
        other => panic!("unexpected field {other:?}"),
    }
}

#[test]
fn bad_scene_names_file_and_line() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("bad.toml");
    std::fs::write(&scene, "[mesh]\ngenerator = { box = { min = [0,0,0], max = [1,1,1], cells = [1,1,1] } }\n\n[solver]\ntime_step = 0.1\n").unwrap();
    let out = tetsim(dir.path(), &["run", "bad.toml"]);
    assert!(!out.status.success());
    let err = stderr(&out);
    assert!(
        err.contains("bad.toml:5:") && err.contains("time_step"),
        "{err}"
    );

    std::fs::write(&scene, "[material]\npoisson_ratio = 0.5\n[mesh]\ngenerator = { box = { min = [0,0,0], max = [1,1,1], cells = [1,1,1] } }\n").unwrap();
    let out = tetsim(dir.path(), &["run", "bad.toml"]);
    assert!(!out.status.success());
    let err = stderr(&out);
    assert!(
        err.contains("bad.toml:2:") && err.contains("poisson_ratio"),
        "{err}"
    );
}

#[test]
fn missing_scene_is_a_clear_error() {
    let dir = tempfile::tempdir().unwrap();
    let out = tetsim(dir.path(), &["run", "nowhere.toml"]);
    assert_eq!(out.status.code(), Some(1));
    assert!(stderr(&out).contains("nowhere.toml"), "{}", stderr(&out));
    assert!(!stderr(&out).contains("panicked"));
}

#[test]
fn empty_region_is_named() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("s.toml"),
        "[mesh]\ngenerator = { box = { min = [0,0,0], max = [1,1,1], cells = [1,1,1] } }\n\n[[fixed]]\nregion = { box = { min = [5,5,5], max = [6,6,6] } }\n",
    )
    .unwrap();
    let out = tetsim(dir.path(), &["run", "s.toml"]);
    assert!(!out.status.success());
    let err = stderr(&out);
    // At the entry's `region` key (line 5), not just its `[[fixed]]` header.
    assert!(
        err.contains("s.toml:5:1: [[fixed]] #1 region: ") && err.contains("no vertices"),
        "{err}"
    );
}

/// Every bad value is refused by the real binary before anything runs: exit code 1, nothing
/// written, and one message naming the file, the exact line of the offending key (inside an
/// inline table or the second `[[fixed]]` entry too) and the key itself.
#[test]
fn bad_scene_values_name_file_line_and_key() {
    const MESH: &str =
        "[mesh]\ngenerator = { box = { min = [0,0,0], max = [1,1,1], cells = [1,1,1] } }\n";
    // (scene text before [mesh], line of the offending key, the key as named, a word of the why)
    let cases: &[(&str, usize, &str, &str)] = &[
        (
            "[solver]\ndt = 0.1\nnewton_tolerance = 0\n",
            3,
            "solver.newton_tolerance",
            "must be positive and finite, got 0",
        ),
        (
            "[solver]\ncg_tolerance = -1\n",
            2,
            "solver.cg_tolerance",
            "got -1",
        ),
        (
            "[solver]\nsubsteps = 0\n",
            2,
            "solver.substeps",
            "at least 1",
        ),
        (
            "[solver]\nframes = 3\n\ndt = 0\n",
            4,
            "solver.dt",
            "positive",
        ),
        (
            "[material]\ndensity = -1\n",
            2,
            "material.density",
            "got -1",
        ),
        (
            "[[fixed]]\nregion = { physical = \"xmin\" }\n\n[[fixed]]\nregion = { physical = \"xmax\" }\nmotion = { translate = [0.1, 0, 0] }\nduration = -1\n",
            7,
            "[[fixed]] #2 duration",
            "got -1",
        ),
        ("gravity = [0.0, nan, 0.0]\n", 1, "gravity", "finite"),
        (
            "[[load]]\nregion = { physical = \"xmax\" }\ntraction = [0, -1, 0]\npoint_force = [0, -1, 0]\n",
            4,
            "[[load]] #1 point_force",
            "exactly one of traction, total_force, point_force",
        ),
        (
            "[material]\nyoungs_modulus = 1e5\npoisson_ratio = 0.5\n",
            3,
            "material.poisson_ratio",
            "(-1, 0.5)",
        ),
        (
            "[[fixed]]\nregion = { box = { min = [0,0,0], max = [1,1,1], mx = [2,2,2] } }\n",
            2,
            "[[fixed]] #1 region.box.mx",
            "unexpected key",
        ),
    ];
    let dir = tempfile::tempdir().unwrap();
    for (i, &(text, line, key, why)) in cases.iter().enumerate() {
        let name = format!("bad{i}.toml");
        std::fs::write(dir.path().join(&name), format!("{text}{MESH}")).unwrap();
        let out = tetsim(dir.path(), &["run", &name, "--out", "out", "-q"]);
        let err = stderr(&out);
        assert_eq!(out.status.code(), Some(1), "{name}: {err}");
        let message = err
            .lines()
            .find(|l| l.starts_with(&format!("error: {name}:")))
            .unwrap_or_else(|| panic!("{name} not named in: {err}"));
        let at_line = format!("error: {name}:{line}:");
        assert!(
            message.starts_with(&at_line),
            "{name}: not line {line}: {message}"
        );
        // After `line:` comes `column: `, then the key path and what is wrong with it.
        let (column, what) = message[at_line.len()..].split_once(": ").unwrap();
        assert!(column.parse::<usize>().is_ok(), "{message}");
        assert!(
            what.starts_with(&format!("{key}: ")),
            "{name}: not {key}: {message}"
        );
        assert!(what.contains(why), "{name}: no `{why}` in: {message}");
        assert!(!err.contains("panicked"), "{err}");
    }
    assert!(
        !dir.path().join("out").exists(),
        "a refused scene wrote output"
    );
}

/// A mesh or positions file the scene names but that does not exist is reported at the key
/// that names it.
#[test]
fn missing_scene_files_are_named_at_their_key() {
    let dir = tempfile::tempdir().unwrap();
    for (text, line, key, file) in [
        (
            "gravity = [0, 0, 0]\n[mesh]\nfile = \"nowhere.msh\"\n",
            3,
            "mesh.file",
            "nowhere.msh",
        ),
        (
            "[mesh]\ngenerator = { box = { min = [0,0,0], max = [1,1,1], cells = [1,1,1] } }\n[initial]\n\npositions = \"squashed.txt\"\n",
            5,
            "initial.positions",
            "squashed.txt",
        ),
    ] {
        std::fs::write(dir.path().join("s.toml"), text).unwrap();
        let out = tetsim(dir.path(), &["run", "s.toml", "-q"]);
        let err = stderr(&out);
        assert_eq!(out.status.code(), Some(1), "{err}");
        assert!(
            err.contains(&format!("s.toml:{line}:1: {key}: ")) && err.contains(file),
            "{err}"
        );
    }
}

#[test]
fn compare_tabulates_every_strategy() {
    let dir = tempfile::tempdir().unwrap();
    let out = tetsim(
        dir.path(),
        &[
            "compare",
            "--frames",
            "2",
            "--definiteness",
            "teran,abs,none",
        ],
    );
    assert!(out.status.success(), "{}", stderr(&out));
    let table = String::from_utf8_lossy(&out.stdout);
    for name in ["teran", "abs", "none"] {
        assert!(
            table.lines().any(|l| l.starts_with(name)),
            "{name} missing in\n{table}"
        );
    }
    let out = tetsim(dir.path(), &["compare", "--definiteness", "sometimes"]);
    assert!(!out.status.success() && stderr(&out).contains("sometimes"));
    // Nothing written: compare runs in memory.
    assert!(std::fs::read_dir(dir.path()).unwrap().next().is_none());
}

#[test]
fn check_passes_on_the_default_scene_and_every_model() {
    let dir = tempfile::tempdir().unwrap();
    let out = tetsim(dir.path(), &["check", "--all-models", "--samples", "4"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let report = String::from_utf8_lossy(&out.stdout);
    for piece in [
        "neo-hookean",
        "corotated",
        "Ψ → P",
        "f → K·u",
        "K·u vs assembled K",
    ] {
        assert!(report.contains(piece), "`{piece}` not in:\n{report}");
    }
    assert_eq!(
        report.matches("PASS: all").count(),
        tetsim::ModelKind::ALL.len(),
        "{report}"
    );
    assert!(!report.contains("FAIL"), "{report}");
}

#[test]
fn check_fails_with_exit_code_one_when_held_to_an_impossible_tolerance() {
    // The same routine with a tolerance no finite difference can meet: every FD row fails, the
    // table says FAIL and the exit code is 1.
    let dir = tempfile::tempdir().unwrap();
    let out = tetsim(dir.path(), &["check", "--tolerance", "1e-30"]);
    assert_eq!(out.status.code(), Some(1), "{}", stderr(&out));
    let report = String::from_utf8_lossy(&out.stdout);
    assert!(report.contains("FAIL"), "{report}");
    assert!(
        stderr(&out).contains("self-check failed"),
        "{}",
        stderr(&out)
    );
}

/// Every file of an output folder, name → bytes, sorted by name.
fn folder(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut files: Vec<(String, Vec<u8>)> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| {
            let path = e.unwrap().path();
            let name = path.file_name().unwrap().to_string_lossy().into_owned();
            (name, std::fs::read(&path).unwrap())
        })
        .collect();
    files.sort();
    files
}

/// steps.csv with the wall_seconds column (the documented exception) blanked.
fn without_wall_seconds(csv: &[u8]) -> String {
    String::from_utf8_lossy(csv)
        .lines()
        .map(|line| {
            let mut cells: Vec<&str> = line.split(',').collect();
            cells[10] = "";
            cells.join(",")
        })
        .collect::<Vec<_>>()
        .join("\n")
}

#[test]
fn same_bytes_on_one_and_two_threads_and_across_runs() {
    let dir = tempfile::tempdir().unwrap();
    let scenes = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    let scene = scenes.join("twist.toml");
    let scene = scene.to_str().unwrap();
    let run = |name: &str, threads: &str, deterministic: bool| {
        let mut args = vec![
            "--threads",
            threads,
            "run",
            scene,
            "--frames",
            "3",
            "--out",
            name,
        ];
        if deterministic {
            args.push("--deterministic");
        }
        let out = tetsim(dir.path(), &args);
        assert!(out.status.success(), "{}", stderr(&out));
        folder(&dir.path().join(name))
    };
    // --deterministic: every file but timings.csv is byte-identical.
    let reference = run("a", "1", true);
    let names: Vec<&str> = reference.iter().map(|f| f.0.as_str()).collect();
    for piece in [
        "frame_0003.vtu",
        "surface_0003.obj",
        "frames.pvd",
        "steps.csv",
        "manifest.json",
    ] {
        assert!(names.contains(&piece), "{piece} missing: {names:?}");
    }
    // timings.csv holds wall-clock times; checkpoint.bin and manifest.json name the folder.
    let strip = |files: Vec<(String, Vec<u8>)>| -> Vec<(String, Vec<u8>)> {
        files
            .into_iter()
            .filter(|f| f.0 != "timings.csv" && f.0 != "checkpoint.bin")
            .map(|(name, bytes)| match name.as_str() {
                "manifest.json" => {
                    let text = String::from_utf8(bytes).unwrap();
                    let kept: Vec<&str> = text
                        .lines()
                        .filter(|l| !l.contains("\"output_dir\""))
                        .collect();
                    (name, kept.join("\n").into_bytes())
                }
                _ => (name, bytes),
            })
            .collect()
    };
    let reference = strip(reference);
    for (name, threads) in [("b", "2"), ("c", "1"), ("d", "2")] {
        let other = strip(run(name, threads, true));
        assert_eq!(reference.len(), other.len());
        for (a, b) in reference.iter().zip(&other) {
            assert_eq!(a.0, b.0);
            assert!(
                a.1 == b.1,
                "{} differs between runs ({threads} threads)",
                a.0
            );
        }
    }
    // Default mode: the same except steps.csv's wall_seconds (and so the manifest's hash of it).
    let timed = run("e", "2", false);
    for (a, b) in reference.iter().zip(
        timed
            .iter()
            .filter(|f| f.0 != "timings.csv" && f.0 != "checkpoint.bin"),
    ) {
        match a.0.as_str() {
            "steps.csv" => assert_eq!(without_wall_seconds(&a.1), without_wall_seconds(&b.1)),
            "manifest.json" => {}
            _ => assert!(a.1 == b.1, "{} differs without --deterministic", a.0),
        }
    }
}

#[test]
fn manifest_records_version_inputs_parameters_and_output_hashes() {
    let dir = tempfile::tempdir().unwrap();
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/squash_recover.toml");
    let out = tetsim(
        dir.path(),
        &[
            "run",
            scene.to_str().unwrap(),
            "--frames",
            "2",
            "--out",
            "o",
        ],
    );
    assert!(out.status.success(), "{}", stderr(&out));
    let text = std::fs::read_to_string(dir.path().join("o/manifest.json")).unwrap();
    let m: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert_eq!(m["tetsim_version"], env!("CARGO_PKG_VERSION"));
    assert_eq!(m["status"], "complete");
    assert_eq!(m["scene"]["sha256"].as_str().unwrap().len(), 64);
    assert_eq!(
        m["inputs"]["initial_positions"]["path"],
        "meshes/cube_flattened.txt"
    );
    assert_eq!(m["parameters"]["material"]["model"], "neo-hookean");
    assert_eq!(m["parameters"]["solver"]["newton_tolerance"], 1e-6);
    assert!(m["parameters"]["resolved"]["mu"].as_f64().unwrap() > 0.0);
    let frames = m["outputs"]["frames"].as_array().unwrap();
    assert_eq!(frames.len(), 3);
    // The hashes are the files' SHA-256.
    let vtu = std::fs::read(dir.path().join("o/frame_0002.vtu")).unwrap();
    assert_eq!(
        frames[2]["files"]["frame_0002.vtu"],
        tetsim::manifest::sha256_hex(&vtu)
    );
}
