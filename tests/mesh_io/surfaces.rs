//! Triangle surfaces in: PLY (ASCII, binary little and big endian, any numeric types, polygons)
//! read to the same surface as the OBJ of it; broken PLY files give located errors.

use std::path::Path;

use tetsim::Vec3;
use tetsim::error::Error;
use tetsim::io::read_surface;

/// A square pyramid: five vertices, four triangles and one quad (fan-split into two).
const VERTICES: [[f64; 3]; 5] = [
    [0.0, 0.0, 0.0],
    [1.0, 0.0, 0.0],
    [1.0, 1.0, 0.0],
    [0.0, 1.0, 0.0],
    [0.5, 0.5, 1.25],
];
const FACES: [&[u32]; 5] = [
    &[0, 3, 2, 1],
    &[0, 1, 4],
    &[1, 2, 4],
    &[2, 3, 4],
    &[3, 0, 4],
];

fn expected() -> Vec<[usize; 3]> {
    vec![
        [0, 3, 2],
        [0, 2, 1],
        [0, 1, 4],
        [1, 2, 4],
        [2, 3, 4],
        [3, 0, 4],
    ]
}

fn ascii_ply() -> String {
    let mut s = String::from(
        "ply\nformat ascii 1.0\ncomment made by a test\nelement vertex 5\nproperty float x\n\
         property float y\nproperty float z\nproperty uchar red\nelement face 5\n\
         property list uchar int vertex_indices\nelement edge 1\nproperty int vertex1\n\
         property int vertex2\nend_header\n",
    );
    for v in VERTICES {
        s += &format!("{} {} {} 255\n", v[0], v[1], v[2]);
    }
    for f in FACES {
        let ids: Vec<String> = f.iter().map(u32::to_string).collect();
        s += &format!("{} {}\n", f.len(), ids.join(" "));
    }
    s + "0 1\n"
}

/// Binary PLY with double coordinates, a float normal, ushort counts and uint indices.
fn binary_ply(big: bool) -> Vec<u8> {
    let format = if big {
        "binary_big_endian"
    } else {
        "binary_little_endian"
    };
    let mut out = format!(
        "ply\nformat {format} 1.0\nelement vertex 5\nproperty double x\nproperty double y\n\
         property double z\nproperty float nx\nelement face 5\n\
         property list ushort uint vertex_indices\nend_header\n"
    )
    .into_bytes();
    let mut put = |bytes: &[u8]| {
        let mut b = bytes.to_vec();
        if big {
            b.reverse();
        }
        out.extend(b);
    };
    for v in VERTICES {
        for c in v {
            put(&c.to_le_bytes());
        }
        put(&1.5f32.to_le_bytes());
    }
    for f in FACES {
        put(&(f.len() as u16).to_le_bytes());
        for &i in f {
            put(&i.to_le_bytes());
        }
    }
    out
}

fn check(path: &Path) {
    let s = read_surface(path).unwrap();
    let want: Vec<Vec3> = VERTICES.iter().map(|v| Vec3::from(*v)).collect();
    assert_eq!(s.positions, want, "{}", path.display());
    assert_eq!(s.faces, expected(), "{}", path.display());
}

#[test]
fn ply_ascii_and_binary_read_the_same_surface() {
    let dir = tempfile::tempdir().unwrap();
    let ascii = dir.path().join("p.ply");
    std::fs::write(&ascii, ascii_ply()).unwrap();
    check(&ascii);
    for big in [false, true] {
        let path = dir.path().join(format!("p{big}.PLY"));
        std::fs::write(&path, binary_ply(big)).unwrap();
        check(&path);
    }
    // The OBJ of the same surface reads alike (1-based indices).
    let mut obj = String::new();
    for v in VERTICES {
        obj += &format!("v {} {} {}\n", v[0], v[1], v[2]);
    }
    for f in FACES {
        let ids: Vec<String> = f.iter().map(|i| (i + 1).to_string()).collect();
        obj += &format!("f {}\n", ids.join(" "));
    }
    let path = dir.path().join("p.obj");
    std::fs::write(&path, obj).unwrap();
    check(&path);
}

fn fails(name: &str, bytes: &[u8], pieces: &[&str]) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join(name);
    std::fs::write(&path, bytes).unwrap();
    let err = read_surface(&path).unwrap_err();
    assert!(matches!(err, Error::Parse { .. }), "{err:?}");
    let text = err.to_string();
    for piece in pieces {
        assert!(text.contains(piece), "`{piece}` not in: {text}");
    }
}

#[test]
fn broken_ply_files_name_the_line_or_element() {
    let good = ascii_ply();
    fails(
        "bad_coord.ply",
        good.replacen("0.5 0.5 1.25", "0.5 zero 1.25", 1).as_bytes(),
        &["bad_coord.ply:19:", "vertex 5", "`zero` is not a number"],
    );
    fails(
        "bad_index.ply",
        good.replacen("3 3 0 4", "3 3 0 9", 1).as_bytes(),
        &["bad_index.ply:24:", "face 5 refers to vertex 9"],
    );
    fails(
        "short.ply",
        good.lines()
            .take(20)
            .collect::<Vec<_>>()
            .join("\n")
            .as_bytes(),
        &["short.ply:", "ends before face 2 of 5"],
    );
    fails(
        "no_end.ply",
        b"ply\nformat ascii 1.0\nelement vertex 0\n",
        &["end_header"],
    );
    fails(
        "type.ply",
        good.replacen("property float y", "property quad y", 1)
            .as_bytes(),
        &["type.ply:6:", "unknown property type `quad`"],
    );
    let mut binary = binary_ply(false);
    binary.truncate(binary.len() - 3);
    fails(
        "cut.ply",
        &binary,
        &["face 5 of 5", "byte offset", "truncated"],
    );
    fails(
        "notply.ply",
        b"solid x\n",
        &["notply.ply:1:", "not a PLY file"],
    );
    fails("surface.off", b"OFF\n", &["unknown surface format `.off`"]);
}
