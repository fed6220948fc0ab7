//! 10-node tets in and out: the fixtures Gmsh 4.15 and meshio 5.3 wrote (`make_quadratic.py`)
//! read the same from every format, keep their mid-edge nodes on their edges (on the curved
//! surface for the cylinder), round-trip through every writer, and broken files give located
//! errors.

use std::path::Path;

use tetsim::error::Error;
use tetsim::io::gmsh::{self, Version};
use tetsim::io::vtu::write_quadratic_vtu;
use tetsim::io::{read_mesh, read_vtu_frame, vtk, write_mesh};
use tetsim::mesh::generate::box_mesh;
use tetsim::mesh::quadratic::{EDGES, SWAP_23, elevate};
use tetsim::{TetMesh, Vec3};

use super::{error_of, read};

const FORMATS: [&str; 6] = [
    "v22.msh",
    "v22_binary.msh",
    "v41.msh",
    "v41_binary.msh",
    "vtk",
    "vtu",
];

fn file(stem: &str, format: &str) -> String {
    match format {
        "vtk" | "vtu" => format!("{stem}.{format}"),
        f => format!("{stem}_{f}"),
    }
}

/// The largest distance of a mid-edge node from its edge's midpoint, relative to the edge.
fn worst_midpoint_offset(mesh: &TetMesh) -> f64 {
    let mut worst = 0.0f64;
    for (t, tet) in mesh.tets.iter().enumerate() {
        for (k, [i, j]) in EDGES.iter().enumerate() {
            let (a, b) = (mesh.positions[tet[*i]], mesh.positions[tet[*j]]);
            let m = mesh.positions[mesh.edge_nodes[t][k]];
            worst = worst.max((m - 0.5 * (a + b)).norm() / (b - a).norm());
        }
    }
    worst
}

/// Same nodes, tets and mid-edge nodes (positions to the 16 digits ASCII files print).
fn assert_same_mesh(a: &TetMesh, b: &TetMesh, what: &str) {
    assert_eq!(a.positions.len(), b.positions.len(), "{what}");
    let worst = a
        .positions
        .iter()
        .zip(&b.positions)
        .map(|(p, q)| (p - q).norm())
        .fold(0.0, f64::max);
    assert!(worst < 1e-14, "{what}: positions differ by {worst}");
    assert_eq!(a.tets, b.tets, "{what}");
    assert_eq!(a.edge_nodes, b.edge_nodes, "{what}");
}

#[test]
fn quadratic_meshes_read_the_same_from_every_gmsh_and_vtk_format() {
    for stem in ["box10", "cylinder10"] {
        let first = read(&file(stem, FORMATS[0]));
        assert!(first.is_quadratic(), "{stem}");
        assert_eq!(first.edge_nodes.len(), first.tets.len());
        for format in &FORMATS[1..] {
            let other = read(&file(stem, format));
            assert_same_mesh(&first, &other, &file(stem, format));
            if format.ends_with("msh") {
                assert_eq!(other.groups, first.groups, "{stem} {format}");
            }
        }
        // Every node is a corner or a mid-edge node of some tet.
        let mut used = vec![false; first.positions.len()];
        for v in first
            .tets
            .iter()
            .flatten()
            .chain(first.edge_nodes.iter().flatten())
        {
            used[*v] = true;
        }
        assert!(used.iter().all(|&u| u), "{stem}");
    }
}

#[test]
fn straight_mid_edge_nodes_sit_at_midpoints_and_curved_ones_near_them() {
    // Gmsh places a box's mid-edge nodes on its flat faces and inside: at the midpoints.
    let box10 = read("box10_v41.msh");
    let straight = worst_midpoint_offset(&box10);
    assert!(straight < 1e-12, "box: {straight}");
    let volume: f64 = (0..box10.tets.len()).map(|t| box10.signed_volume(t)).sum();
    assert!((volume - 2.0).abs() < 1e-12, "{volume}");
    // On the cylinder's mantle they are pulled out onto the circle: off the chord, not far.
    let cylinder = read("cylinder10_v41_binary.msh");
    let curved = worst_midpoint_offset(&cylinder);
    assert!(curved > 1e-3 && curved < 0.2, "cylinder: {curved}");
    let mantle = cylinder.group("mantle").expect("mantle");
    for &v in &mantle.vertices {
        let p = cylinder.positions[v];
        let r = (p.x * p.x + p.y * p.y).sqrt();
        assert!((r - 0.5).abs() < 1e-9, "node {v} at radius {r}");
    }
}

#[test]
fn face_groups_of_six_node_triangles_hold_every_node_of_their_faces() {
    let mesh = read("box10_v22_binary.msh");
    let clamp = mesh.group("clamp").expect("clamp");
    let body = mesh.group("body").expect("body");
    assert_eq!(body.tets.len(), mesh.tets.len());
    assert_eq!(body.vertices.len(), mesh.positions.len());
    // Corners and mid-edge nodes alike: every node on x = 0 is clamped.
    let on_face = mesh.positions.iter().filter(|p| p.x == 0.0).count();
    assert_eq!(clamp.vertices.len(), on_face);
    assert!(!clamp.faces.is_empty());
    // Faces are the triangles' corners: each is a face of some tet.
    let corners: std::collections::HashSet<usize> = mesh.tets.iter().flatten().copied().collect();
    assert!(clamp.faces.iter().flatten().all(|v| corners.contains(v)));
    // Sub-triangles of the boundary: four per curved face, all nodes on the surface.
    let boundary = mesh.boundary_faces();
    let on_clamp = boundary
        .iter()
        .filter(|f| f.iter().all(|&v| mesh.positions[v].x == 0.0))
        .count();
    assert_eq!(on_clamp, 4 * clamp.faces.len());
}

#[test]
fn quadratic_meshes_round_trip_through_every_writer() {
    let original = read("cylinder10_v41.msh");
    let dir = tempfile::tempdir().unwrap();
    for name in ["m.msh", "m.vtu", "m.vtk"] {
        let path = dir.path().join(name);
        write_mesh(&path, &original).unwrap();
        let back = read_mesh(&path).unwrap().mesh;
        assert_same_mesh(&original, &back, name);
        if name.ends_with("msh") {
            assert_eq!(back.groups, original.groups);
        }
    }
    for (name, version, binary) in [
        ("b.msh", Version::V41, true),
        ("c.msh", Version::V22, false),
    ] {
        let path = dir.path().join(name);
        gmsh::write(&path, &original, version, binary).unwrap();
        let back = read_mesh(&path).unwrap().mesh;
        assert_same_mesh(&original, &back, name);
        assert_eq!(back.groups, original.groups, "{name}");
    }
    let path = dir.path().join("a.vtk");
    vtk::write(&path, &original, false).unwrap();
    assert_same_mesh(&original, &read_mesh(&path).unwrap().mesh, "ASCII vtk");
    // Formats without 10-node tets refuse rather than silently linearise.
    for name in ["m.node", "m.mesh"] {
        let err = write_mesh(&dir.path().join(name), &original).unwrap_err();
        assert!(err.to_string().contains("10-node"), "{err}");
    }
}

#[test]
fn reading_reorients_quadratic_tets_with_their_edge_nodes() {
    let mut mesh = elevate(&box_mesh(
        Vec3::zeros(),
        Vec3::new(2.0, 1.0, 1.0),
        [2, 1, 1],
    ));
    // Flip every other tet as a file with mixed orientations would hold it.
    for t in (0..mesh.tets.len()).step_by(2) {
        mesh.tets[t].swap(2, 3);
        mesh.edge_nodes[t] = SWAP_23.map(|k| mesh.edge_nodes[t][k]);
    }
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("flipped.vtu");
    write_mesh(&path, &mesh).unwrap();
    let read = read_mesh(&path).unwrap();
    assert_eq!(read.report.reoriented, mesh.tets.len().div_ceil(2));
    assert!((0..read.mesh.tets.len()).all(|t| read.mesh.signed_volume(t) > 0.0));
    assert!(worst_midpoint_offset(&read.mesh) < 1e-15);
}

#[test]
fn quadratic_vtu_frames_read_back_with_their_edge_nodes() {
    let mesh = read("box10.vtu");
    let cells: Vec<[usize; 10]> = (0..mesh.tets.len())
        .map(|t| mesh.quadratic_nodes(t))
        .collect();
    let j: Vec<f64> = (0..cells.len()).map(|t| t as f64).collect();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("frame_0000.vtu");
    let field = tetsim::io::Field::Scalar(&j);
    write_quadratic_vtu(&path, &mesh.positions, &cells, &[], &[("J", field)]).unwrap();
    let frame = read_vtu_frame(&path).unwrap();
    assert_eq!(frame.tets, mesh.tets);
    assert_eq!(frame.edge_nodes, mesh.edge_nodes);
    assert_eq!(frame.points, mesh.positions);
}

fn parse_error(name: &str) -> (Option<usize>, String) {
    match error_of(name) {
        (Error::Parse { line, message, .. }, text) => {
            assert!(text.contains(name), "{text}");
            (line, message)
        }
        (e, _) => panic!("{name}: not a parse error: {e}"),
    }
}

#[test]
fn mixed_order_meshes_are_refused_naming_file_and_elements() {
    let (line, message) = parse_error("bad/mixed_order_v22.msh");
    assert_eq!(line, Some(21));
    assert!(message.contains("element 2 is a 4-node"), "{message}");
    assert!(message.contains("element 1 (line 20)"), "{message}");
    let (_, message) = parse_error("bad/mixed_order.vtk");
    assert!(
        message.contains("cell 1 is a 4-node tet but cell 0"),
        "{message}"
    );
}

#[test]
fn bad_quadratic_cells_name_the_element_and_node() {
    let (err, text) = error_of("bad/missing_edge_node_v22.msh");
    assert!(matches!(err, Error::Mesh { .. }), "{err}");
    assert!(text.contains("missing_edge_node_v22.msh"), "{text}");
    assert!(text.contains("99") && text.contains('1'), "{text}");
    let (_, message) = parse_error("bad/short_quadratic.vtu");
    assert!(
        message.contains("cell 0") && message.contains("8 points"),
        "{message}"
    );
}

/// meshio reads our 10-node VTU as `tetra10` with the same points and connectivity (its own
/// node order is VTK's). Needs meshio, as [`super::meshio_reads_our_vtu`].
#[test]
#[ignore]
fn meshio_reads_our_quadratic_vtu() {
    let python = std::env::var("TETSIM_PYTHON").unwrap_or_else(|_| "python3".into());
    let mesh = read("cylinder10_v41.msh");
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("q.vtu");
    write_mesh(&path, &mesh).unwrap();
    let points: Vec<[f64; 3]> = mesh.positions.iter().map(|p| [p.x, p.y, p.z]).collect();
    let cells: Vec<[usize; 10]> = (0..mesh.tets.len())
        .map(|t| mesh.quadratic_nodes(t))
        .collect();
    let script = format!(
        "import meshio, numpy as np\nm = meshio.read(r'{}')\n\
         assert [c.type for c in m.cells] == ['tetra10'], m.cells\n\
         assert np.array_equal(m.points, np.array({:?}))\n\
         assert np.array_equal(m.cells[0].data, np.array({:?}))\nprint('ok')",
        Path::new(&path).display(),
        points,
        cells,
    );
    let out = std::process::Command::new(&python)
        .args(["-c", &script])
        .output()
        .expect("python3");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// Frames of a renumbered run are written in the file's order: corners and mid-edge nodes map
/// back through the same renumbering.
#[test]
fn renumbered_quadratic_cells_map_back_to_the_file_order() {
    use tetsim::mesh::ordering::{Renumbering, VertexOrder};
    let mesh = read("cylinder10_v41.msh");
    let r = Renumbering::new(&mesh, VertexOrder::Random).expect("a renumbering");
    let renumbered = r.apply(&mesh);
    assert_ne!(renumbered.tets, mesh.tets);
    assert_eq!(r.tets_to_old_mesh(&renumbered.tets), mesh.tets);
    assert_eq!(r.tets_to_old_mesh(&renumbered.edge_nodes), mesh.edge_nodes);
}
