//! Tier 2: meshes in and out. Every fixture in `tests/fixtures/` (written by Gmsh 4.15, TetGen
//! 1.5 and meshio 5.3) reads with the right counts, groups and volume; every writer round-trips
//! exactly; every broken file in `tests/fixtures/bad/` gives its specific, located error; and no
//! input bytes make a reader panic.

mod common;
#[path = "mesh_io/quadratic.rs"]
mod quadratic;
#[path = "mesh_io/stuffing.rs"]
mod stuffing;
#[path = "mesh_io/surfaces.rs"]
mod surfaces;

use std::f64::consts::PI;
use std::path::{Path, PathBuf};

use proptest::prelude::*;
use tetsim::error::{Error, MeshProblem};
use tetsim::io::gmsh::Version;
use tetsim::io::vtu::{VtuOptions, read_pvd, write_vtu_with};
use tetsim::io::{
    Field, FieldData, ReadOptions, read_mesh, read_mesh_with, read_vtu_frame, write_mesh,
    write_pvd, write_vtu,
};
use tetsim::mesh::generate::box_mesh;
use tetsim::{TetMesh, Vec3};

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures")
        .join(name)
}

fn read(name: &str) -> TetMesh {
    let path = fixture(name);
    read_mesh(&path)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
        .mesh
}

fn volume(mesh: &TetMesh) -> f64 {
    (0..mesh.tets.len()).map(|t| mesh.signed_volume(t)).sum()
}

#[test]
fn beam_reads_the_same_from_msh_v22_v41_ascii_and_v41_binary() {
    let v22 = read("beam_v22.msh");
    let v41 = read("beam_v41.msh");
    let bin = read("beam_v41_binary.msh");
    assert_eq!(v41.positions.len(), 458);
    assert_eq!(v41.tets.len(), 1471);
    for other in [&v22, &bin] {
        // The ASCII files print 16 significant digits; the binary one holds the exact doubles.
        let worst = other
            .positions
            .iter()
            .zip(&v41.positions)
            .map(|(a, b)| (a - b).norm())
            .fold(0.0, f64::max);
        assert_eq!(other.positions.len(), v41.positions.len());
        assert!(worst < 1e-15, "positions differ by {worst}");
        assert_eq!(other.tets, v41.tets);
        assert_eq!(other.groups, v41.groups);
    }
    // The box [0,4]×[0,1]×[0,1] has flat faces: the mesh fills it up to round-off.
    assert!((volume(&v41) - 4.0).abs() < 1e-12, "{}", volume(&v41));
}

#[test]
fn beam_physical_groups_are_found_by_name() {
    let mesh = read("beam_v41_binary.msh");
    let clamp = mesh.group("clamp").expect("clamp");
    let tip = mesh.group("tip").expect("tip");
    let body = mesh.group("body").expect("body");
    assert_eq!((clamp.dim, clamp.tag, tip.tag, body.tag), (2, 1, 2, 3));
    assert_eq!(body.tets.len(), mesh.tets.len());
    assert_eq!(clamp.faces.len(), 44);
    assert!(clamp.vertices.iter().all(|&v| mesh.positions[v].x == 0.0));
    assert!(tip.vertices.iter().all(|&v| mesh.positions[v].x == 4.0));
    // Every boundary vertex on x = 0 is in the clamp group.
    let on_face = mesh.positions.iter().filter(|p| p.x == 0.0).count();
    assert_eq!(clamp.vertices.len(), on_face);
}

#[test]
fn load_report_lists_triangles_used_only_for_groups() {
    let read = read_mesh(&fixture("beam_v41.msh")).unwrap();
    assert_eq!(read.report.format, "Gmsh 4.1 ASCII");
    assert_eq!(read.report.ignored, vec![("triangle".to_string(), 88)]);
    assert!(read.report.dropped_vertices.is_empty());
    assert!(read.diagnosis.is_ok());
    assert_eq!(read.diagnosis.euler_characteristic, 2);
}

#[test]
fn tetgen_ball_has_its_counts_markers_and_volume() {
    let mesh = read("ball.node");
    assert_eq!(mesh.positions.len(), 1013);
    assert_eq!(mesh.tets.len(), 3559);
    // 1-based ids as in the files.
    assert_eq!(mesh.vertex_id(0), 1);
    assert_eq!(mesh.tet_id(0), 1);
    let marker = mesh
        .group("marker_1")
        .expect("boundary marker group from .face");
    assert_eq!(marker.faces.len(), 1554);
    // A polyhedron inscribed in the unit ball with edges ≈ 0.2: within 4% below 4π/3.
    let exact = 4.0 / 3.0 * PI;
    let v = volume(&mesh);
    assert!(v < exact && v > 0.96 * exact, "{v} vs {exact}");
    assert_eq!(read("ball.ele"), mesh);
}

#[test]
fn torus_reads_the_same_from_vtu_vtk_ascii_and_vtk_binary() {
    let vtu = read("torus.vtu");
    let vtk = read("torus.vtk");
    let bin = read("torus_binary.vtk");
    assert_eq!(vtu.positions.len(), 517);
    assert_eq!(vtu.tets.len(), 1650);
    for other in [&vtk, &bin] {
        assert_eq!(other.tets, vtu.tets);
        for (a, b) in other.positions.iter().zip(&vtu.positions) {
            // The ASCII file prints 16 significant digits.
            assert!((a - b).norm() < 1e-14);
        }
    }
    // 2π²Rr² for R = 1, r = 0.35; the coarse mesh cuts the tube's circle (~4% below).
    let exact = 2.0 * PI * PI * 0.35 * 0.35;
    let v = volume(&vtu);
    assert!(v < exact && v > 0.95 * exact, "{v} vs {exact}");
    let d = read_mesh(&fixture("torus.vtu")).unwrap().diagnosis;
    assert_eq!(d.euler_characteristic, 0, "a torus");
}

/// Every tetsim writer, then read back.
fn round_trip(mesh: &TetMesh, file: &str) -> TetMesh {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join(file);
    write_mesh(&path, mesh).unwrap();
    read_mesh(&path).unwrap().mesh
}

#[test]
fn gmsh_round_trips_are_exact_with_groups() {
    let beam = read("beam_v41.msh");
    let dir = tempfile::tempdir().unwrap();
    for (version, binary) in [
        (Version::V41, false),
        (Version::V41, true),
        (Version::V22, false),
    ] {
        let path = dir.path().join("out.msh");
        tetsim::io::gmsh::write(&path, &beam, version, binary).unwrap();
        let back = read_mesh(&path).unwrap().mesh;
        assert_eq!(back.positions, beam.positions, "{version:?} {binary}");
        assert_eq!(back.tets, beam.tets);
        assert_eq!(back.groups, beam.groups);
    }
}

#[test]
fn vtu_keeps_groups_as_named_arrays_of_linear_and_quadratic_tets() {
    for name in ["beam_v41.msh", "box10_v41.msh"] {
        let mesh = read(name);
        assert!(!mesh.groups.is_empty(), "{name}");
        let back = round_trip(&mesh, "out.vtu");
        assert_eq!(back.positions, mesh.positions, "{name}");
        assert_eq!(back.tets, mesh.tets, "{name}");
        assert_eq!(back.edge_nodes, mesh.edge_nodes, "{name}");
        assert_eq!(back.groups.len(), mesh.groups.len(), "{name}");
        for (b, g) in back.groups.iter().zip(&mesh.groups) {
            // Names, members and dimension come back; a VTU array has no numeric tag.
            assert_eq!((&b.name, b.dim), (&g.name, g.dim), "{name}");
            assert_eq!(b.vertices, g.vertices, "{name} {}", g.name);
            assert_eq!(b.faces, g.faces, "{name} {}", g.name);
            assert_eq!(b.tets, g.tets, "{name} {}", g.name);
        }
    }
}

#[test]
fn every_format_round_trips_positions_and_tets_exactly() {
    let mut rng = common::rng(7);
    let mesh = common::small_mesh(&mut rng);
    for file in ["m.msh", "m.vtu", "m.vtk", "m.node", "m.mesh"] {
        let back = round_trip(&mesh, file);
        assert_eq!(back.positions, mesh.positions, "{file}");
        assert_eq!(back.tets, mesh.tets, "{file}");
    }
    // Vertex-only groups (the box generator's faces) come back as point groups.
    let back = round_trip(&mesh, "m.msh");
    let xmin = back.group("xmin").unwrap();
    assert_eq!(xmin.vertices, mesh.group("xmin").unwrap().vertices);
    assert_eq!(xmin.dim, 0);
}

#[test]
fn negatively_oriented_tets_are_reoriented_and_counted() {
    let mut mesh = box_mesh(Vec3::zeros(), Vec3::repeat(1.0), [2, 1, 1]);
    for t in [0, 3, 7] {
        mesh.tets[t].swap(0, 1);
    }
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("flipped.msh");
    write_mesh(&path, &mesh).unwrap();
    let read = read_mesh(&path).unwrap();
    assert_eq!(read.report.reoriented, 3);
    assert!((0..read.mesh.tets.len()).all(|t| read.mesh.signed_volume(t) > 0.0));
    assert!(read.report.to_string().contains("reoriented 3"));
}

#[test]
fn unreferenced_vertices_are_dropped_and_renumbering_reported() {
    let dir = tempfile::tempdir().unwrap();
    let node = dir.path().join("m.node");
    std::fs::write(
        &node,
        "6 3 0 0\n0 9 9 9\n1 0 0 0\n2 1 0 0\n3 7 7 7\n4 0 1 0\n5 0 0 1\n",
    )
    .unwrap();
    std::fs::write(dir.path().join("m.ele"), "1 4 0\n0 1 2 4 5\n").unwrap();
    let read = read_mesh(&node).unwrap();
    assert_eq!(read.report.dropped_vertices, vec![0, 3]);
    assert_eq!(read.mesh.tets, vec![[0, 1, 2, 3]]);
    assert_eq!(read.mesh.vertex_ids, Some(vec![1, 2, 4, 5]));
    assert!(read.report.to_string().contains("dropped 2 vertices"));
}

#[test]
fn vtu_frames_round_trip_with_data_in_every_encoding() {
    let mut rng = common::rng(3);
    let mesh = common::small_mesh(&mut rng);
    let n = mesh.positions.len();
    let displacement = common::random_field(&mut rng, n);
    let speed: Vec<f64> = (0..n).map(|i| i as f64 * 0.25 - 1.0).collect();
    let j: Vec<f64> = (0..mesh.tets.len())
        .map(|t| 1.0 + t as f64 * 1e-3)
        .collect();
    let dir = tempfile::tempdir().unwrap();
    for (k, (base64, zlib)) in [(false, false), (false, true), (true, false), (true, true)]
        .into_iter()
        .enumerate()
    {
        let path = dir.path().join(format!("frame_{k:04}.vtu"));
        let write = |p: &Path| {
            write_vtu_with(
                p,
                &mesh.positions,
                &mesh.tets,
                &[
                    ("displacement", Field::Vector(&displacement)),
                    ("speed", Field::Scalar(&speed)),
                ],
                &[("J", Field::Scalar(&j))],
                VtuOptions { base64, zlib },
            )
            .unwrap()
        };
        write(&path);
        let frame = read_vtu_frame(&path).unwrap();
        assert_eq!(frame.points, mesh.positions);
        assert_eq!(frame.tets, mesh.tets);
        assert_eq!(
            frame.point_field("displacement"),
            Some(&FieldData::Vector(displacement.clone()))
        );
        assert_eq!(
            frame.point_field("speed"),
            Some(&FieldData::Scalar(speed.clone()))
        );
        assert_eq!(frame.cell_field("J"), Some(&FieldData::Scalar(j.clone())));
        // Deterministic: the same input gives the same bytes.
        let again = dir.path().join("again.vtu");
        write(&again);
        assert_eq!(
            std::fs::read(&path).unwrap(),
            std::fs::read(&again).unwrap()
        );
    }
}

#[test]
fn vtu_rejects_fields_of_the_wrong_length() {
    let mesh = box_mesh(Vec3::zeros(), Vec3::repeat(1.0), [1, 1, 1]);
    let dir = tempfile::tempdir().unwrap();
    let err = write_vtu(
        &dir.path().join("x.vtu"),
        &mesh.positions,
        &mesh.tets,
        &[("velocity", Field::Scalar(&[1.0]))],
        &[],
    )
    .unwrap_err();
    assert!(err.to_string().contains("point data `velocity`"), "{err}");
}

#[test]
fn pvd_lists_frames_with_times() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("frames.pvd");
    let entries = vec![
        (0.0, "frame_0000.vtu".to_string()),
        (1.0 / 30.0, "frame_0001.vtu".to_string()),
    ];
    write_pvd(&path, &entries).unwrap();
    assert_eq!(read_pvd(&path).unwrap(), entries);
}

#[test]
fn obj_surface_is_the_outward_boundary() {
    let mesh = read("beam_v41.msh");
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("surface.obj");
    write_mesh(&path, &mesh).unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    let v: Vec<Vec3> = text
        .lines()
        .filter_map(|l| l.strip_prefix("v "))
        .map(|l| {
            let c: Vec<f64> = l.split(' ').map(|x| x.parse().unwrap()).collect();
            Vec3::new(c[0], c[1], c[2])
        })
        .collect();
    let faces: Vec<[usize; 3]> = text
        .lines()
        .filter_map(|l| l.strip_prefix("f "))
        .map(|l| {
            let i: Vec<usize> = l.split(' ').map(|x| x.parse().unwrap()).collect();
            [i[0] - 1, i[1] - 1, i[2] - 1]
        })
        .collect();
    assert_eq!(faces.len(), 762);
    // Divergence theorem: outward faces enclose the mesh's volume with a positive sign.
    let enclosed: f64 = faces
        .iter()
        .map(|f| v[f[0]].dot(&v[f[1]].cross(&v[f[2]])) / 6.0)
        .sum();
    assert!((enclosed - 4.0).abs() < 1e-12, "{enclosed}");
}

// ---- Broken files: the specific error, located. ----

fn error_of(name: &str) -> (Error, String) {
    let err = read_mesh(&fixture(name)).expect_err(name);
    let text = err.to_string();
    (err, text)
}

#[test]
fn bad_truncated_msh_names_file_and_line() {
    let (err, text) = error_of("bad/truncated_v41.msh");
    assert!(
        matches!(
            err,
            Error::Parse {
                line: Some(987),
                ..
            }
        ),
        "{err:?}"
    );
    assert!(text.contains("truncated_v41.msh:987:"), "{text}");
    assert!(text.contains("truncated"), "{text}");
}

#[test]
fn bad_missing_node_names_element_and_node() {
    for name in ["bad/missing_node.node", "bad/missing_node.ele"] {
        let (err, text) = error_of(name);
        assert!(
            matches!(
                err,
                Error::Mesh {
                    problem: MeshProblem::IndexOutOfRange { tet: 2, vertex: 99 },
                    ..
                }
            ),
            "{err:?}"
        );
        assert!(
            text.contains("missing_node.ele: element 2 refers to node 99"),
            "{text}"
        );
    }
}

#[test]
fn bad_degenerate_tet_is_refused_unless_forced() {
    let (err, text) = error_of("bad/degenerate.node");
    assert!(
        matches!(
            &err,
            Error::Mesh { problem: MeshProblem::Degenerate { tets }, .. } if tets == &[2]
        ),
        "{err:?}"
    );
    assert!(
        text.contains("degenerate.ele: degenerate element"),
        "{text}"
    );
    let forced = read_mesh_with(&fixture("bad/degenerate.node"), ReadOptions { force: true });
    assert_eq!(forced.unwrap().diagnosis.degenerate, vec![1]);
}

#[test]
fn bad_nan_coordinate_names_the_node() {
    let (err, text) = error_of("bad/nan_coordinate.ele");
    assert!(
        matches!(
            err,
            Error::Mesh {
                problem: MeshProblem::NonFinite { vertex: 2 },
                ..
            }
        ),
        "{err:?}"
    );
    assert!(text.contains("nan_coordinate.node: node 2"), "{text}");
}

#[test]
fn bad_not_a_mesh_says_so_at_line_one() {
    let (err, text) = error_of("bad/not_a_mesh.msh");
    assert!(matches!(err, Error::Parse { line: Some(1), .. }), "{err:?}");
    assert!(text.contains("not_a_mesh.msh:1: not a Gmsh mesh"), "{text}");
}

#[test]
fn bad_triangles_only_has_no_tetrahedra() {
    let (err, text) = error_of("bad/triangles_only_v22.msh");
    assert!(
        matches!(
            err,
            Error::Mesh {
                problem: MeshProblem::NoTetrahedra,
                ..
            }
        ),
        "{err:?}"
    );
    assert!(
        text.contains("triangles_only_v22.msh: the mesh has no tetrahedra"),
        "{text}"
    );
}

#[test]
fn missing_file_and_unknown_extension_are_clear() {
    let err = read_mesh(Path::new("/nonexistent/beam.msh")).unwrap_err();
    assert!(matches!(err, Error::Io { .. }), "{err:?}");
    let err = read_mesh(Path::new("beam.stl")).unwrap_err().to_string();
    assert!(err.contains("unknown mesh format `.stl`"), "{err}");
}

// ---- No panic on any bytes. ----

/// Read `bytes` as a file named `name` (TetGen: as the `.ele` beside a good `.node`).
fn read_garbage(dir: &Path, name: &str, bytes: &[u8]) {
    let path = dir.join(name);
    std::fs::write(&path, bytes).unwrap();
    if name.ends_with(".ele") {
        std::fs::copy(
            fixture("bad/missing_node.node"),
            path.with_extension("node"),
        )
        .unwrap();
    }
    // Any result is fine; a panic fails the test.
    let _ = read_mesh_with(&path, ReadOptions { force: true });
    if name.ends_with(".vtu") {
        let _ = read_vtu_frame(&path);
    }
}

fn fuzz_cases() -> u32 {
    std::env::var("TETSIM_FUZZ_CASES")
        .ok()
        .and_then(|n| n.parse().ok())
        .unwrap_or(48)
}

const GARBAGE_NAMES: [&str; 6] = ["g.msh", "g.ele", "g.vtk", "g.vtu", "g.mesh", "g.node"];

fn seeds() -> Vec<(&'static str, Vec<u8>)> {
    [
        ("g.msh", "beam_v41.msh"),
        ("g.msh", "beam_v41_binary.msh"),
        ("g.msh", "beam_v22.msh"),
        ("g.vtk", "torus_binary.vtk"),
        ("g.vtk", "torus.vtk"),
        ("g.vtu", "torus.vtu"),
        ("g.ele", "bad/missing_node.ele"),
        ("g.msh", "box10_v22_binary.msh"),
        ("g.vtk", "box10.vtk"),
    ]
    .into_iter()
    .map(|(n, f)| (n, std::fs::read(fixture(f)).unwrap()))
    .collect()
}

proptest! {
    // 48 cases each in CI; `TETSIM_FUZZ_CASES=5000 cargo test --release --test mesh_io survive`
    // fuzzes for longer.
    #![proptest_config(ProptestConfig { cases: fuzz_cases(), ..ProptestConfig::default() })]

    #[test]
    fn readers_survive_random_bytes(bytes in proptest::collection::vec(any::<u8>(), 0..400), which in 0..6usize) {
        let dir = tempfile::tempdir().unwrap();
        read_garbage(dir.path(), GARBAGE_NAMES[which], &bytes);
    }

    #[test]
    fn readers_survive_mutated_real_files(
        seed in 0..9usize,
        cut in 0.0..1.0f64,
        flips in proptest::collection::vec((0.0..1.0f64, any::<u8>()), 0..8),
    ) {
        let (name, mut bytes) = seeds().swap_remove(seed);
        for (at, byte) in flips {
            let last = bytes.len() - 1;
            let i = (at * bytes.len() as f64) as usize;
            bytes[i.min(last)] = byte;
        }
        bytes.truncate((cut * bytes.len() as f64) as usize + 1);
        let dir = tempfile::tempdir().unwrap();
        read_garbage(dir.path(), name, &bytes);
    }

    #[test]
    fn readers_survive_token_soup(tokens in proptest::collection::vec(
        prop_oneof![
            Just("$MeshFormat".to_string()), Just("4.1 0 8".to_string()), Just("2.2 1 8".to_string()),
            Just("$Nodes".to_string()), Just("$Elements".to_string()), Just("$Entities".to_string()),
            Just("$EndNodes".to_string()), Just("POINTS".to_string()), Just("CELLS".to_string()),
            Just("OFFSETS vtktypeint64".to_string()), Just("CELL_TYPES".to_string()),
            Just("Vertices".to_string()), Just("Tetrahedra".to_string()),
            Just("<DataArray format=\"appended\" offset=\"9\">".to_string()),
            Just("\"".to_string()), Just("-1".to_string()), Just("18446744073709551615".to_string()),
            Just("nan".to_string()), (0..20u32).prop_map(|i| i.to_string()),
        ], 0..60), which in 0..6usize) {
        let text = tokens.join("\n");
        let text = match which {
            2 => format!("# vtk DataFile Version 5.1\nt\nASCII\nDATASET UNSTRUCTURED_GRID\n{text}"),
            3 => format!("<VTKFile type=\"UnstructuredGrid\"><UnstructuredGrid><Piece NumberOfPoints=\"1\" NumberOfCells=\"1\">{text}"),
            4 => format!("MeshVersionFormatted 2\nDimension 3\n{text}"),
            _ => text,
        };
        let dir = tempfile::tempdir().unwrap();
        read_garbage(dir.path(), GARBAGE_NAMES[which], text.as_bytes());
    }
}

/// meshio (the Python mesh I/O library) reads our VTU frame with its data arrays. Needs
/// `python3 -c "import meshio"` to work; run with `cargo test -- --ignored meshio`, or set
/// `TETSIM_PYTHON` to a Python that has meshio.
#[test]
#[ignore]
fn meshio_reads_our_vtu() {
    let python = std::env::var("TETSIM_PYTHON").unwrap_or_else(|_| "python3".into());
    let mesh = box_mesh(Vec3::zeros(), Vec3::new(2.0, 1.0, 1.0), [2, 1, 1]);
    let u: Vec<Vec3> = mesh.positions.iter().map(|p| p * 0.5).collect();
    let j: Vec<f64> = (0..mesh.tets.len()).map(|t| t as f64).collect();
    let dir = tempfile::tempdir().unwrap();
    for (k, (base64, zlib)) in [(false, false), (false, true), (true, false), (true, true)]
        .into_iter()
        .enumerate()
    {
        let path = dir.path().join(format!("f{k}.vtu"));
        write_vtu_with(
            &path,
            &mesh.positions,
            &mesh.tets,
            &[("displacement", Field::Vector(&u))],
            &[("J", Field::Scalar(&j))],
            VtuOptions { base64, zlib },
        )
        .unwrap();
        let script = format!(
            "import meshio, numpy as np\nm = meshio.read(r'{}')\n\
             assert m.points.shape == ({}, 3)\nassert m.cells[0].type == 'tetra'\n\
             assert np.array_equal(m.cells[0].data, np.array({:?}))\n\
             assert np.allclose(m.point_data['displacement'], 0.5 * m.points)\n\
             assert np.array_equal(m.cell_data['J'][0], np.arange({}))\nprint('ok')",
            path.display(),
            mesh.positions.len(),
            mesh.tets,
            mesh.tets.len()
        );
        let out = std::process::Command::new(&python)
            .args(["-c", &script])
            .output()
            .expect("python3");
        assert!(
            out.status.success(),
            "{base64} {zlib}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
}
