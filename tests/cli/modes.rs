//! `tetsim modes` and `[solver] damping_ratio` (SPEC §13) through the real binary.

use std::path::Path;

use tetsim::io::FieldData;
use tetsim::{ElasticBody, Lame, Model, ModelKind, TetMesh, Vec3};

use super::beam24::box_mesh_24;
use super::{stderr, tetsim};

const TWO_PI: f64 = 2.0 * std::f64::consts::PI;

/// A 3 × 1 × 1 beam meshed with the cube's symmetry (so its bending pair is exact), clamped at
/// x = 0, as `beam.vtu` and `s.toml` in a temp dir; `solver` is appended to the scene.
fn symmetric_cantilever(solver: &str) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    let mesh = box_mesh_24(Vec3::new(3.0, 1.0, 1.0), [6, 2, 2]);
    tetsim::io::write_mesh(&dir.path().join("beam.vtu"), &mesh).unwrap();
    let scene = format!(
        "[mesh]\nfile = \"beam.vtu\"\n\n[material]\nyoungs_modulus = 2.0e5\npoisson_ratio = 0.3\n\
         density = 1000.0\n\n[[fixed]]\nregion = {{ box = {{ min = [-0.01, -1, -1], max = [0.01, 2, 2] }} }}\n{solver}"
    );
    std::fs::write(dir.path().join("s.toml"), scene).unwrap();
    dir
}

/// modes.csv's frequencies, after checking its header.
fn frequencies(csv: &Path) -> Vec<f64> {
    let text = std::fs::read_to_string(csv).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some("mode,frequency_hz"));
    lines
        .enumerate()
        .map(|(i, line)| {
            let (mode, f) = line.split_once(',').unwrap();
            assert_eq!(mode.parse::<usize>().unwrap(), i);
            f.parse().unwrap()
        })
        .collect()
}

#[test]
fn modes_writes_sorted_frequencies_mass_normalised_shapes_and_the_pair() {
    let dir = symmetric_cantilever("");
    let out = tetsim(
        dir.path(),
        &["modes", "s.toml", "--count", "6", "--out", "modes"],
    );
    assert!(out.status.success(), "{}", stderr(&out));
    let folder = dir.path().join("modes");
    let f = frequencies(&folder.join("modes.csv"));
    assert_eq!(f.len(), 6);
    assert!(f.windows(2).all(|w| w[0] <= w[1]), "not ascending: {f:?}");
    assert!(f[0] > 0.0);
    // The first bending pair: two equal frequencies.
    assert!((f[1] - f[0]).abs() <= 1e-6 * f[0], "no pair: {f:?}");
    assert!(f[2] > 1.01 * f[1], "{f:?}");
    let pvd = tetsim::io::vtu::read_pvd(&folder.join("modes.pvd")).unwrap();
    assert_eq!(pvd.len(), 6);
    let model = Model::new(ModelKind::NeoHookean, Lame::from_young_poisson(2.0e5, 0.3));
    for (i, (_, name)) in pvd.iter().enumerate() {
        assert_eq!(name, &format!("mode_{i:02}.vtu"));
        let gif = std::fs::read(folder.join(format!("mode_{i:02}.gif"))).unwrap();
        assert_eq!(&gif[..6], b"GIF89a");
        // Read the shape back; the lumped mass from the file's own rest mesh.
        let frame = tetsim::io::read_vtu_frame(&folder.join(name)).unwrap();
        let Some(FieldData::Vector(shape)) = frame.point_field("shape") else {
            panic!("{name}: no vector `shape`");
        };
        let mesh = TetMesh::new(frame.points.clone(), frame.tets.clone());
        let body = ElasticBody::new(mesh, model, 1000.0).unwrap();
        let norm: f64 = shape
            .iter()
            .zip(body.masses())
            .map(|(p, m)| m * p.norm_squared())
            .sum();
        assert!((norm - 1.0).abs() < 1e-9, "{name}: φᵀMφ = {norm}");
        // Zero on the clamp, moving elsewhere.
        for (p, phi) in frame.points.iter().zip(shape) {
            if p.x == 0.0 {
                assert_eq!(*phi, Vec3::zeros());
            }
        }
        assert!(shape.iter().any(|phi| phi.norm() > 0.0));
    }
    // A second call with fewer modes leaves no stale files behind.
    let out = tetsim(
        dir.path(),
        &[
            "modes",
            "s.toml",
            "--count",
            "2",
            "--out",
            "modes",
            "--no-pictures",
        ],
    );
    assert!(out.status.success(), "{}", stderr(&out));
    assert_eq!(frequencies(&folder.join("modes.csv")).len(), 2);
    assert!(!folder.join("mode_02.vtu").exists() && !folder.join("mode_00.gif").exists());
}

#[test]
fn a_free_body_s_first_six_modes_are_rigid() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("s.toml"),
        "[mesh]\ngenerator = { box = { min = [0,0,0], max = [2,0.5,0.5], cells = [8,2,2] } }\n",
    )
    .unwrap();
    let out = tetsim(
        dir.path(),
        &[
            "modes",
            "s.toml",
            "--count",
            "8",
            "--out",
            "m",
            "--no-pictures",
        ],
    );
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(
        stderr(&out).contains("6 rigid-body motion(s)"),
        "{}",
        stderr(&out)
    );
    let f = frequencies(&dir.path().join("m/modes.csv"));
    assert!(f[..6].iter().all(|&r| r == 0.0), "{f:?}");
    assert!(f[6] > 0.0 && f[7] >= f[6]);
}

#[test]
fn modes_are_the_same_bytes_on_one_and_two_threads() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("s.toml"),
        "[mesh]\ngenerator = { box = { min = [0,0,0], max = [2,0.5,0.5], cells = [8,2,2] } }\n\
         [[fixed]]\nregion = { physical = \"xmin\" }\n",
    )
    .unwrap();
    for threads in ["1", "2"] {
        let out = tetsim(
            dir.path(),
            &[
                "--threads",
                threads,
                "modes",
                "s.toml",
                "--count",
                "4",
                "--out",
                threads,
                "--no-pictures",
            ],
        );
        assert!(out.status.success(), "{}", stderr(&out));
    }
    for name in ["modes.csv", "modes.pvd", "mode_00.vtu", "mode_03.vtu"] {
        let one = std::fs::read(dir.path().join("1").join(name)).unwrap();
        let two = std::fs::read(dir.path().join("2").join(name)).unwrap();
        assert!(one == two, "{name} differs between 1 and 2 threads");
    }
}

#[test]
fn modes_refuses_counts_it_cannot_honour() {
    let dir = symmetric_cantilever("");
    let out = tetsim(dir.path(), &["modes", "s.toml", "--count", "0"]);
    assert_eq!(out.status.code(), Some(1));
    assert!(stderr(&out).contains("--count must be at least 1"));
    let out = tetsim(
        dir.path(),
        &["modes", "s.toml", "--count", "100000", "--no-pictures"],
    );
    assert_eq!(out.status.code(), Some(1));
    assert!(
        stderr(&out).contains("free degrees of freedom"),
        "{}",
        stderr(&out)
    );
    assert!(!stderr(&out).contains("panicked"));
}

/// Run `s.toml` for one frame; the manifest.
fn run_manifest(dir: &Path) -> serde_json::Value {
    let out = tetsim(
        dir,
        &[
            "run",
            "s.toml",
            "--frames",
            "1",
            "--out",
            "o",
            "--no-pictures",
        ],
    );
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(stderr(&out).contains("damping ratio"), "{}", stderr(&out));
    let text = std::fs::read_to_string(dir.join("o/manifest.json")).unwrap();
    serde_json::from_str(&text).unwrap()
}

#[test]
fn a_damping_ratio_resolves_to_rayleigh_coefficients_by_the_formula() {
    let (zeta, f1, f2) = (0.05, 2.0, 30.0);
    let dir = symmetric_cantilever(&format!(
        "\n[solver]\ndt = 0.01\ndamping_ratio = {zeta}\ndamping_frequencies = [{f1}, {f2}]\n"
    ));
    let m = run_manifest(dir.path());
    let (w1, w2) = (TWO_PI * f1, TWO_PI * f2);
    let alpha = 2.0 * zeta * w1 * w2 / (w1 + w2);
    let gamma = 2.0 * zeta / (w1 + w2);
    let damping = &m["parameters"]["resolved"]["damping"];
    let close = |v: &serde_json::Value, want: f64| {
        let got = v.as_f64().unwrap();
        assert!((got - want).abs() <= 1e-12 * want, "{got} vs {want}");
    };
    close(&damping["rayleigh_mass"], alpha);
    close(&damping["rayleigh_stiffness"], gamma);
    close(&m["parameters"]["solver"]["rayleigh_mass"], alpha);
    close(&m["parameters"]["solver"]["rayleigh_stiffness"], gamma);
    assert_eq!(damping["frequencies_from"], "scene");
    assert_eq!(damping["damping_ratio"], zeta);
}

#[test]
fn default_damping_frequencies_are_the_lowest_mode_and_ten_times_it() {
    let dir = symmetric_cantilever("\n[solver]\ndt = 0.01\ndamping_ratio = 0.02\n");
    let m = run_manifest(dir.path());
    let out = tetsim(
        dir.path(),
        &[
            "modes",
            "s.toml",
            "--count",
            "1",
            "--out",
            "m",
            "--no-pictures",
        ],
    );
    assert!(out.status.success(), "{}", stderr(&out));
    let lowest = frequencies(&dir.path().join("m/modes.csv"))[0];
    let damping = &m["parameters"]["resolved"]["damping"];
    assert_eq!(damping["frequencies_from"], "lowest mode");
    let used: Vec<f64> = damping["damping_frequencies"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap())
        .collect();
    assert!(
        (used[0] - lowest).abs() <= 1e-6 * lowest,
        "{used:?} vs {lowest}"
    );
    assert!((used[1] - 10.0 * used[0]).abs() <= 1e-12 * used[1]);
    let (w1, w2) = (TWO_PI * used[0], TWO_PI * used[1]);
    let gamma = damping["rayleigh_stiffness"].as_f64().unwrap();
    assert!((gamma - 0.04 / (w1 + w2)).abs() <= 1e-12 * gamma);
}

#[test]
fn damping_errors_are_refused_at_their_line() {
    for (solver, line, key, word) in [
        (
            "[solver]\ndamping_ratio = 0.02\nrayleigh_mass = 0.5\n",
            13,
            "solver.rayleigh_mass",
            "damping_ratio (line 12)",
        ),
        (
            "[solver]\ndamping_ratio = 0.02\ndamping_frequencies = [10.0, 2.0]\n",
            13,
            "solver.damping_frequencies",
            "above the first",
        ),
        (
            "[solver]\ndamping_frequencies = [1.0, 2.0]\n",
            12,
            "solver.damping_frequencies",
            "needs solver.damping_ratio",
        ),
    ] {
        let dir = symmetric_cantilever(solver);
        let out = tetsim(dir.path(), &["run", "s.toml", "--out", "o", "-q"]);
        let err = stderr(&out);
        assert_eq!(out.status.code(), Some(1), "{err}");
        assert!(
            err.starts_with(&format!("error: s.toml:{line}:")),
            "line {line}: {err}"
        );
        assert!(err.contains(key) && err.contains(word), "{err}");
    }
}
