//! Quadratic tets through the command line: a 10-node mesh written by Gmsh runs as a scene, and
//! its frames are 10-node VTU cells that read back with every node where the run put it.

use super::*;

/// The Gmsh box of 10-node tets clamped on its `clamp` face (a group of 6-node triangles)
/// sags under gravity: every frame is written as 10-node cells, the clamped corners and
/// mid-edge nodes stay at rest, the free end moves, and the mid-edge nodes of the far face
/// lie between their corners (the element is bent, not torn).
#[test]
fn a_gmsh_mesh_of_ten_node_tets_runs_and_writes_ten_node_frames() {
    let dir = staged(&["box10_v41.msh"]);
    std::fs::write(
        dir.path().join("scene.toml"),
        r#"
gravity = [0.0, -9.81, 0.0]
[mesh]
file = "box10_v41.msh"
[material]
model = "neo-hookean"
youngs_modulus = 1.0e5
poisson_ratio = 0.3
density = 1000.0
[[fixed]]
region = { physical = "clamp" }
[solver]
dt = 0.05
frames = 3
"#,
    )
    .unwrap();
    let out = tetsim(
        dir.path(),
        &["run", "scene.toml", "--out", "out", "--no-pictures"],
    );
    assert!(out.status.success(), "{}", stderr(&out));
    let frame = tetsim::io::vtu::read_vtu_frame(&dir.path().join("out/frame_0003.vtu")).unwrap();
    assert!(!frame.tets.is_empty());
    assert_eq!(frame.edge_nodes.len(), frame.tets.len());
    let Some(tetsim::io::FieldData::Vector(u)) = frame.point_field("displacement") else {
        panic!("no displacement");
    };
    let rest: Vec<tetsim::Vec3> = frame.points.iter().zip(u).map(|(x, u)| x - u).collect();
    let (mut clamped, mut far) = (0, 0.0f64);
    for (v, p) in rest.iter().enumerate() {
        if p.x.abs() < 1e-9 {
            clamped += 1;
            assert!(u[v].norm() < 1e-12, "clamped node {v} moved {}", u[v]);
        }
        if (p.x - 2.0).abs() < 1e-9 {
            far = far.max(u[v].norm());
        }
    }
    assert!(clamped > 8, "{clamped} nodes at x = 0");
    assert!(far > 1e-3, "the free end did not move: {far}");
    for (t, e) in frame.edge_nodes.iter().enumerate() {
        for (k, [i, j]) in tetsim::mesh::quadratic::EDGES.iter().enumerate() {
            let (a, b) = (frame.tets[t][*i], frame.tets[t][*j]);
            let mid = 0.5 * (frame.points[a] + frame.points[b]);
            let edge = (frame.points[a] - frame.points[b]).norm();
            assert!(
                (frame.points[e[k]] - mid).norm() < 0.1 * edge,
                "tet {t} edge {k}"
            );
        }
    }
}
