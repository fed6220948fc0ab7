//! `tetsim mesh tetrahedralize` and `[mesh] surface` through the real binary.

use std::fmt::Write as _;
use std::path::Path;

use super::{stderr, tetsim};

/// An octahedron-refined sphere of radius `r` (in the file's units) as an OBJ.
fn write_sphere_obj(path: &Path, r: f64) {
    // A UV sphere: poles plus rings, outward oriented.
    let (rings, segments) = (12, 24);
    let mut obj = String::new();
    writeln!(obj, "v 0 0 {r}").unwrap();
    for i in 1..rings {
        let theta = std::f64::consts::PI * i as f64 / rings as f64;
        for j in 0..segments {
            let phi = 2.0 * std::f64::consts::PI * j as f64 / segments as f64;
            let (x, y, z) = (
                r * theta.sin() * phi.cos(),
                r * theta.sin() * phi.sin(),
                r * theta.cos(),
            );
            writeln!(obj, "v {x} {y} {z}").unwrap();
        }
    }
    writeln!(obj, "v 0 0 {}", -r).unwrap();
    let ring = |i: usize, j: usize| 2 + (i - 1) * segments + j % segments;
    let south = 2 + (rings - 1) * segments;
    for j in 0..segments {
        writeln!(obj, "f 1 {} {}", ring(1, j), ring(1, j + 1)).unwrap();
        writeln!(
            obj,
            "f {south} {} {}",
            ring(rings - 1, j + 1),
            ring(rings - 1, j)
        )
        .unwrap();
    }
    for i in 1..rings - 1 {
        for j in 0..segments {
            let (a, b, c, d) = (
                ring(i, j),
                ring(i + 1, j),
                ring(i + 1, j + 1),
                ring(i, j + 1),
            );
            writeln!(obj, "f {a} {b} {c} {d}").unwrap();
        }
    }
    std::fs::write(path, obj).unwrap();
}

#[test]
fn tetrahedralize_writes_a_mesh_and_reports_its_quality() {
    let dir = tempfile::tempdir().unwrap();
    write_sphere_obj(&dir.path().join("ball.obj"), 1.0);
    let out = tetsim(
        dir.path(),
        &[
            "mesh",
            "tetrahedralize",
            "ball.obj",
            "ball.msh",
            "--size",
            "0.25",
        ],
    );
    assert!(out.status.success(), "{}", stderr(&out));
    let text = String::from_utf8_lossy(&out.stdout);
    for piece in [
        "tets",
        "dihedral angles",
        "volume",
        "Hausdorff distance",
        "time",
    ] {
        assert!(text.contains(piece), "`{piece}` not in: {text}");
    }
    let read = tetsim::io::read_mesh(&dir.path().join("ball.msh")).unwrap();
    assert!(read.diagnosis.is_ok(), "{}", read.diagnosis);
    assert_eq!(read.report.reoriented, 0);
    let volume: f64 = (0..read.mesh.tets.len())
        .map(|t| read.mesh.signed_volume(t))
        .sum();
    assert!(
        (volume - 4.0 / 3.0 * std::f64::consts::PI).abs() < 0.3,
        "{volume}"
    );
    // A size with a unit: millimetres of a 1 m ball give too many tets for any memory.
    let out = tetsim(
        dir.path(),
        &[
            "mesh",
            "tetrahedralize",
            "ball.obj",
            "ball.vtu",
            "--size",
            "0.01 mm",
        ],
    );
    assert_eq!(out.status.code(), Some(1));
    let err = stderr(&out);
    assert!(err.contains("--size") && err.contains("tets"), "{err}");
    assert!(!dir.path().join("ball.vtu").exists());
}

#[test]
fn tetrahedralize_refuses_an_open_surface_and_a_bad_size() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("sheet.obj"),
        "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n",
    )
    .unwrap();
    let out = tetsim(
        dir.path(),
        &[
            "mesh",
            "tetrahedralize",
            "sheet.obj",
            "sheet.vtu",
            "--size",
            "0.1",
        ],
    );
    assert_eq!(out.status.code(), Some(1));
    let err = stderr(&out);
    assert!(
        err.contains("sheet.obj") && err.contains("too open"),
        "{err}"
    );
    write_sphere_obj(&dir.path().join("ball.obj"), 1.0);
    let out = tetsim(
        dir.path(),
        &[
            "mesh",
            "tetrahedralize",
            "ball.obj",
            "ball.vtu",
            "--size",
            "-1",
        ],
    );
    assert_eq!(out.status.code(), Some(1));
    assert!(stderr(&out).contains("positive"), "{}", stderr(&out));
    assert!(!stderr(&out).contains("panicked"));
}

#[test]
fn a_scene_fills_its_surface_at_load() {
    let dir = tempfile::tempdir().unwrap();
    write_sphere_obj(&dir.path().join("ball.obj"), 100.0);
    let scene = "[mesh]\nsurface = \"ball.obj\"\nunit = \"mm\"\nsize = \"40 mm\"\n\n\
                 [solver]\nframes = 1\n\n[output]\npictures = false\n";
    std::fs::write(dir.path().join("s.toml"), scene).unwrap();
    let out = tetsim(dir.path(), &["run", "s.toml", "--out", "out"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let frame = tetsim::io::read_vtu_frame(&dir.path().join("out/frame_0000.vtu")).unwrap();
    assert!(frame.tets.len() > 100);
    // Rest positions in metres: the 100 mm ball.
    let reach = frame.points.iter().fold(0.0f64, |m, p| m.max(p.norm()));
    assert!((reach - 0.1).abs() < 0.04, "{reach}");

    // A surface without size, and a surface beside a file, are named at their key.
    std::fs::write(
        dir.path().join("t.toml"),
        "[mesh]\nsurface = \"ball.obj\"\n",
    )
    .unwrap();
    let out = tetsim(dir.path(), &["run", "t.toml"]);
    assert_eq!(out.status.code(), Some(1));
    let err = stderr(&out);
    assert!(
        err.contains("t.toml:2:") && err.contains("needs `size`"),
        "{err}"
    );
    std::fs::write(
        dir.path().join("u.toml"),
        "[mesh]\nfile = \"x.msh\"\nsurface = \"ball.obj\"\nsize = 0.1\n",
    )
    .unwrap();
    let out = tetsim(dir.path(), &["run", "u.toml"]);
    assert_eq!(out.status.code(), Some(1));
    let err = stderr(&out);
    assert!(
        err.contains("u.toml:3:") && err.contains("not both"),
        "{err}"
    );
}
