//! Obstacles and the surface readers, on real files in a temp dir and the repository fixtures.

use std::path::{Path, PathBuf};

use super::*;

fn closed_volume(s: &TriangleSurface) -> f64 {
    let x = &s.positions;
    s.faces
        .iter()
        .map(|&[a, b, c]| x[a].dot(&x[b].cross(&x[c])) / 6.0)
        .sum()
}

fn write(dir: &Path, name: &str, bytes: &[u8]) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, bytes).unwrap();
    path
}

fn message(e: Error) -> String {
    e.to_string()
}

#[test]
fn box_is_a_closed_outward_surface() {
    let (min, max) = (Vec3::new(-1.0, 0.0, 2.0), Vec3::new(1.0, 0.5, 3.0));
    let o = Obstacle::new(Shape::Box { min, max }, Motion::default()).unwrap();
    let t = o.triangles();
    assert_eq!((t.positions.len(), t.faces.len()), (8, 12));
    assert!((closed_volume(t) - 1.0).abs() < 1e-12);
    let s = o.contact_surface();
    assert_eq!((s.vertices.len(), s.edges.len()), (8, 18));
    let center = 0.5 * (min + max);
    for &[a, b, c] in &t.faces {
        let x = &t.positions;
        assert!((x[b] - x[a]).cross(&(x[c] - x[a])).dot(&(x[a] - center)) > 0.0);
    }
}

#[test]
fn motion_moves_every_shape_rigidly() {
    let motion = Motion {
        translate: Vec3::new(0.0, -1.0, 0.0),
        rotate_degrees: 90.0,
        axis: Vec3::z(),
        center: Vec3::zeros(),
    };
    let plane = Obstacle::new(
        Shape::Plane {
            point: Vec3::x(),
            normal: Vec3::new(0.0, 3.0, 0.0),
        },
        motion,
    )
    .unwrap();
    let (p, n) = plane.plane_at(1.0).unwrap();
    assert!((p - Vec3::new(0.0, 0.0, 0.0)).norm() < 1e-12, "{p}");
    assert!((n - Vec3::new(-1.0, 0.0, 0.0)).norm() < 1e-12, "{n}");
    let (p, n) = plane.plane_at(0.0).unwrap();
    assert_eq!((p, n), (Vec3::x(), Vec3::y()));
    let sphere = Obstacle::new(
        Shape::Sphere {
            center: Vec3::x(),
            radius: 0.5,
        },
        motion,
    )
    .unwrap();
    assert_eq!(
        sphere.sphere_at(1.0).unwrap().0,
        motion.apply(1.0, &Vec3::x())
    );
    assert!(sphere.positions_at(1.0).is_empty());
    let cube = Obstacle::new(
        Shape::Box {
            min: Vec3::zeros(),
            max: Vec3::repeat(1.0),
        },
        motion,
    )
    .unwrap();
    for s in [0.0, 0.3, 1.0] {
        let x = cube.positions_at(s);
        for (a, b) in x.iter().zip(&cube.triangles().positions) {
            assert_eq!(*a, motion.apply(s, b));
        }
        // Rigid: the volume is kept.
        let moved = TriangleSurface {
            positions: x,
            faces: cube.triangles().faces.clone(),
        };
        assert!((closed_volume(&moved) - 1.0).abs() < 1e-12);
    }
}

#[test]
fn invalid_shapes_are_refused() {
    let m = Motion::default();
    let bad = [
        Shape::Plane {
            point: Vec3::zeros(),
            normal: Vec3::zeros(),
        },
        Shape::Plane {
            point: Vec3::new(f64::NAN, 0.0, 0.0),
            normal: Vec3::y(),
        },
        Shape::Box {
            min: Vec3::zeros(),
            max: Vec3::new(1.0, 0.0, 1.0),
        },
        Shape::Sphere {
            center: Vec3::zeros(),
            radius: 0.0,
        },
        Shape::Mesh(TriangleSurface::default()),
        Shape::Mesh(TriangleSurface {
            positions: vec![Vec3::zeros(); 3],
            faces: vec![[0, 1, 3]],
        }),
    ];
    for shape in bad {
        assert!(Obstacle::new(shape.clone(), m).is_err(), "{shape:?}");
    }
}

const OBJ_CUBE: &str = "# a unit cube, quads, with texture/normal indices
o cube
v 0 0 0
v 1 0 0
v 1 1 0
v 0 1 0
v 0 0 1
v 1 0 1
v 1 1 1
v 0 1 1
vn 0 0 1
f 1/1/1 4/1/1 3/1/1 2/1/1
f 5 6 7 8
f 1 2 6 5
f 2 3 7 6
f 3 4 8 7
f -4 -8 -5 -1
";

#[test]
fn obj_reader_reads_polygons_and_relative_indices() {
    let dir = tempfile::tempdir().unwrap();
    let path = write(dir.path(), "cube.obj", OBJ_CUBE.as_bytes());
    let s = read_surface(&path).unwrap();
    assert_eq!((s.positions.len(), s.faces.len()), (8, 12));
    assert!((closed_volume(&s) - 1.0).abs() < 1e-12);
    let o = Obstacle::from_file(&path, Motion::default()).unwrap();
    assert_eq!(o.contact_surface().edges.len(), 18);
}

#[test]
fn obj_reader_errors_name_file_and_line() {
    let dir = tempfile::tempdir().unwrap();
    let cases = [
        (
            "nan.obj",
            "v 0 0 0\nv 1 0 nan\nv 0 1 0\nf 1 2 3\n",
            ":2:",
            "non-finite",
        ),
        (
            "inf.obj",
            "v 0 0 0\nv 1 0 0\nv 0 inf 0\nf 1 2 3\n",
            ":3:",
            "non-finite",
        ),
        (
            "missing.obj",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\n\nf 1 2 4\n",
            ":5:",
            "vertex 4",
        ),
        (
            "zero.obj",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n",
            ":4:",
            "vertex 0",
        ),
        ("two.obj", "v 0 0 0\nv 1 0 0\nf 1 2\n", ":3:", "2 vertices"),
        ("word.obj", "v 0 0 zero\n", ":1:", "not a number"),
        (
            "empty.obj",
            "# nothing\nv 0 0 0\n",
            "empty.obj",
            "no triangles",
        ),
    ];
    for (name, text, at, what) in cases {
        let path = write(dir.path(), name, text.as_bytes());
        let e = message(read_surface(&path).unwrap_err());
        assert!(
            e.contains(name) && e.contains(at) && e.contains(what),
            "{name}: {e}"
        );
    }
}

/// A closed tetrahedron as STL triangles (outward).
fn tet_triangles() -> Vec<[Vec3; 3]> {
    let x = [Vec3::zeros(), Vec3::x(), Vec3::y(), Vec3::z()];
    [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]]
        .iter()
        .map(|f| f.map(|i| x[i]))
        .collect()
}

fn ascii_stl(tris: &[[Vec3; 3]]) -> String {
    let mut s = String::from("solid tet\n");
    for t in tris {
        s += "  facet normal 0 0 0\n    outer loop\n";
        for v in t {
            s += &format!("      vertex {} {} {}\n", v.x, v.y, v.z);
        }
        s += "    endloop\n  endfacet\n";
    }
    s + "endsolid tet\n"
}

fn binary_stl(tris: &[[Vec3; 3]], header: &[u8]) -> Vec<u8> {
    let mut b = vec![0u8; 80];
    b[..header.len()].copy_from_slice(header);
    b.extend((tris.len() as u32).to_le_bytes());
    for t in tris {
        b.extend([0f32; 3].iter().flat_map(|c| c.to_le_bytes()));
        for v in t {
            b.extend(v.iter().flat_map(|&c| (c as f32).to_le_bytes()));
        }
        b.extend([0u8, 0]);
    }
    b
}

#[test]
fn stl_reader_reads_ascii_and_binary_and_merges_corners() {
    let dir = tempfile::tempdir().unwrap();
    let tris = tet_triangles();
    let ascii = write(dir.path(), "tet.stl", ascii_stl(&tris).as_bytes());
    // A binary file whose header starts with "solid", as many exporters write.
    let binary = write(
        dir.path(),
        "tet_bin.STL",
        &binary_stl(&tris, b"solid binary"),
    );
    for path in [ascii, binary] {
        let s = read_surface(&path).unwrap();
        assert_eq!((s.positions.len(), s.faces.len()), (4, 4), "{path:?}");
        assert!((closed_volume(&s) - 1.0 / 6.0).abs() < 1e-7);
        let o = Obstacle::from_file(&path, Motion::default()).unwrap();
        assert_eq!(o.contact_surface().edges.len(), 6);
    }
}

#[test]
fn stl_reader_errors_are_located() {
    let dir = tempfile::tempdir().unwrap();
    let mut tris = tet_triangles();
    let nan_ascii = ascii_stl(&tris).replacen("vertex 0 1 0", "vertex 0 NaN 0", 1);
    let path = write(dir.path(), "nan.stl", nan_ascii.as_bytes());
    let e = message(read_surface(&path).unwrap_err());
    assert!(e.contains("nan.stl:5:") && e.contains("non-finite"), "{e}");
    let four = ascii_stl(&tris).replacen("    endloop", "      vertex 1 1 1\n    endloop", 1);
    let path = write(dir.path(), "four.stl", four.as_bytes());
    let e = message(read_surface(&path).unwrap_err());
    assert!(e.contains("four.stl:2:") && e.contains("4 vertices"), "{e}");
    let path = write(
        dir.path(),
        "empty.stl",
        b"solid nothing\nendsolid nothing\n",
    );
    let e = message(read_surface(&path).unwrap_err());
    assert!(e.contains("no triangles"), "{e}");
    tris[2][1].y = f64::INFINITY;
    let path = write(dir.path(), "inf.stl", &binary_stl(&tris, b"binary"));
    let e = message(read_surface(&path).unwrap_err());
    assert!(
        e.contains("triangle 3") && e.contains("byte offset 196"),
        "{e}"
    );
    let path = write(dir.path(), "cut.stl", &binary_stl(&tris, b"binary")[..150]);
    assert!(read_surface(&path).is_err());
}

#[test]
fn tet_mesh_files_give_their_boundary() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures");
    for name in ["beam_v41.msh", "torus.vtk", "ball.node"] {
        let s = read_surface(&root.join(name)).unwrap();
        assert!(!s.faces.is_empty());
        // Closed: every edge on exactly two triangles.
        let c = ContactSurface::from_triangles(s.faces.clone());
        assert_eq!(2 * c.edges.len(), 3 * s.faces.len(), "{name}");
        assert_eq!(c.vertices.len(), s.positions.len());
        assert!(closed_volume(&s) > 0.0, "{name}: outward");
    }
    let e = message(read_surface(&root.join("bad/triangles_only_v22.msh")).unwrap_err());
    assert!(e.contains("no tetrahedra"), "{e}");
    assert!(read_surface(&root.join("bad/nan_coordinate.node")).is_err());
}
