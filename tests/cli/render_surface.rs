//! Render surfaces: `render = "x.obj"` writes `render_NNNN.obj` every frame (texture
//! coordinates, groups and materials kept) and `render.glb`, whose morph targets reproduce the
//! frames; a surface far from the mesh is refused with its file, line and vertex.

use super::{stderr, tetsim};
use std::path::Path;

/// A cube surface of quads inside the box [0, 1]³ mesh, one vertex exactly on a mesh corner,
/// with texture coordinates, two groups and two materials.
const SURFACE: &str = "mtllib cube.mtl
o cube
v 0 0 0
v 0.9 0.1 0.1
v 0.9 0.9 0.1
v 0.1 0.9 0.1
v 0.1 0.1 0.9
v 0.9 0.1 0.9
v 0.9 0.9 0.9
v 0.1 0.9 0.9
vt 0 0
vt 1 0
vt 1 1
vt 0 1
g bottom
usemtl red
f 1/1 4/2 3/3 2/4
f 5/1 6/2 7/3 8/4
g sides
usemtl blue
f 1/1 2/2 6/3 5/4
f 2/1 3/2 7/3 6/4
f 3/1 4/2 8/3 7/4
f 4/1 1/2 5/3 8/4
";

const SCENE: &str = r#"gravity = [0.0, -9.81, 0.0]
[mesh]
generator = { box = { min = [0, 0, 0], max = [1, 1, 1], cells = [2, 2, 2] } }
render = "cube.obj"
[material]
youngs_modulus = 2e4
[[fixed]]
region = { box = { min = [-0.01, -1, -1], max = [0.01, 2, 2] } }
[solver]
dt = 0.02
frames = 3
[output]
pictures = false
plots = false
"#;

fn f32_at(bin: &[u8], offset: usize) -> f32 {
    f32::from_le_bytes(bin[offset..offset + 4].try_into().unwrap())
}

/// The VEC3 data of accessor `a` of a parsed glTF.
fn vec3s(json: &serde_json::Value, bin: &[u8], a: usize) -> Vec<[f32; 3]> {
    let acc = &json["accessors"][a];
    let view = &json["bufferViews"][acc["bufferView"].as_u64().unwrap() as usize];
    let start = view["byteOffset"].as_u64().unwrap() as usize;
    (0..acc["count"].as_u64().unwrap() as usize)
        .map(|i| [0, 1, 2].map(|k| f32_at(bin, start + 12 * i + 4 * k)))
        .collect()
}

fn obj_positions(path: &Path) -> Vec<[f64; 3]> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .filter_map(|l| l.strip_prefix("v "))
        .map(|l| {
            let c: Vec<f64> = l.split_whitespace().map(|x| x.parse().unwrap()).collect();
            [c[0], c[1], c[2]]
        })
        .collect()
}

#[test]
fn a_run_writes_render_frames_and_a_gltf_whose_targets_are_the_frames() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("cube.obj"), SURFACE).unwrap();
    std::fs::write(
        dir.path().join("cube.mtl"),
        "newmtl red\nKd 1 0 0\nnewmtl blue\nKd 0 0 1\n",
    )
    .unwrap();
    std::fs::write(dir.path().join("s.toml"), SCENE).unwrap();
    let out = tetsim(dir.path(), &["run", "s.toml", "--out", "out", "-q"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let out_dir = dir.path().join("out");
    for k in 0..=3 {
        let text = std::fs::read_to_string(out_dir.join(format!("render_{k:04}.obj"))).unwrap();
        assert_eq!(text.lines().filter(|l| l.starts_with("vt ")).count(), 4);
        assert_eq!(text.lines().filter(|l| l.starts_with("vn ")).count(), 8);
        for line in [
            "mtllib cube.mtl",
            "g bottom",
            "g sides",
            "usemtl blue",
            "f 1/1/1 4/2/4 3/3/3 2/4/2",
        ] {
            assert!(text.lines().any(|l| l == line), "frame {k} lacks `{line}`");
        }
    }
    assert!(out_dir.join("cube.mtl").is_file());
    // The vertex on the mesh's corner (0, 0, 0) is fixed there: it stays exactly.
    assert_eq!(
        obj_positions(&out_dir.join("render_0003.obj"))[0],
        [0.0, 0.0, 0.0]
    );

    // render.glb, parsed by hand: header, JSON chunk, BIN chunk.
    let glb = std::fs::read(out_dir.join("render.glb")).unwrap();
    assert_eq!(&glb[0..4], b"glTF");
    assert_eq!(
        u32::from_le_bytes(glb[8..12].try_into().unwrap()) as usize,
        glb.len()
    );
    let json_len = u32::from_le_bytes(glb[12..16].try_into().unwrap()) as usize;
    assert_eq!(&glb[16..20], b"JSON");
    let json: serde_json::Value = serde_json::from_slice(&glb[20..20 + json_len]).unwrap();
    let bin = &glb[20 + json_len + 8..];
    assert_eq!(&glb[20 + json_len + 4..20 + json_len + 8], b"BIN\0");
    let mesh = &json["meshes"][0];
    let prims = mesh["primitives"].as_array().unwrap();
    assert_eq!(prims.len(), 2, "one primitive per material");
    let names: Vec<&str> = json["materials"]
        .as_array()
        .unwrap()
        .iter()
        .map(|m| m["name"].as_str().unwrap())
        .collect();
    assert_eq!(names, ["red", "blue"]);
    assert_eq!(
        json["materials"][0]["pbrMetallicRoughness"]["baseColorFactor"][0],
        1.0
    );
    let base = vec3s(
        &json,
        bin,
        prims[0]["attributes"]["POSITION"].as_u64().unwrap() as usize,
    );
    let targets = prims[0]["targets"].as_array().unwrap();
    assert_eq!(
        targets.len(),
        3,
        "one morph target per frame after the first"
    );
    let sampler = &json["animations"][0]["samplers"][0];
    assert_eq!(
        json["accessors"][sampler["input"].as_u64().unwrap() as usize]["count"],
        4
    );
    for (k, target) in targets.iter().enumerate() {
        let delta = vec3s(&json, bin, target["POSITION"].as_u64().unwrap() as usize);
        let frame = obj_positions(&out_dir.join(format!("render_{:04}.obj", k + 1)));
        // Each glTF vertex (a position with its texture coordinate) is a vertex of the frame.
        for (b, d) in base.iter().zip(&delta) {
            let p = [0, 1, 2].map(|i| (b[i] + d[i]) as f64);
            let nearest = frame
                .iter()
                .map(|q| (0..3).map(|i| (p[i] - q[i]).abs()).fold(0.0, f64::max))
                .fold(f64::INFINITY, f64::min);
            assert!(
                nearest < 1e-6,
                "frame {}: glTF vertex {p:?} is {nearest} from the OBJ's",
                k + 1
            );
        }
    }
}

#[test]
fn a_render_surface_far_from_the_mesh_is_refused_naming_the_vertex() {
    let dir = tempfile::tempdir().unwrap();
    let far = SURFACE.replace("v 0.9 0.9 0.9", "v 0.9 0.9 3.0");
    std::fs::write(dir.path().join("cube.obj"), far).unwrap();
    std::fs::write(dir.path().join("s.toml"), SCENE).unwrap();
    let out = tetsim(dir.path(), &["run", "s.toml", "--out", "out", "-q"]);
    assert_eq!(out.status.code(), Some(1));
    let err = stderr(&out);
    for piece in [
        "s.toml:4",
        "mesh.render",
        "vertex 7",
        "2.000e0 m",
        "tolerance",
    ] {
        assert!(err.contains(piece), "`{piece}` not in: {err}");
    }
}
