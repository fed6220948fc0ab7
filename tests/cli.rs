//! Tier 4: the real `tetsim` binary in a temporary folder: outputs, exit codes, messages.

use std::path::Path;
use std::process::{Command, Output};

fn tetsim(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_tetsim"))
        .args(args)
        .current_dir(dir)
        .output()
        .expect("the tetsim binary runs")
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

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
        let vtu = std::fs::read_to_string(out_dir.join(format!("frame_{frame:04}.vtu"))).unwrap();
        let values = float64_arrays(&vtu);
        assert!(
            values.len() > 1000 && values.iter().all(|v| v.is_finite()),
            "frame {frame} has non-finite values"
        );
    }
    let vtu = std::fs::read_to_string(out_dir.join("frame_0003.vtu")).unwrap();
    for array in [
        "\"displacement\"",
        "\"velocity\"",
        "\"J\"",
        "\"strain_energy_density\"",
        "\"von_mises\"",
    ] {
        assert!(vtu.contains(array), "frame VTU lacks {array}");
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
    // Nothing left behind half-written.
    assert!(
        std::fs::read_dir(&out_dir).unwrap().all(|e| !e
            .unwrap()
            .file_name()
            .to_string_lossy()
            .ends_with(".tmp"))
    );
}

/// Every Float64 value of a binary (base64, UInt64 header) VTU.
fn float64_arrays(vtu: &str) -> Vec<f64> {
    let mut values = Vec::new();
    for piece in vtu.split("<DataArray").skip(1) {
        if !piece.contains("type=\"Float64\"") {
            continue;
        }
        let data = &piece[piece.find('>').unwrap() + 1..piece.find("</DataArray>").unwrap()];
        let bytes = decode_base64(data.trim());
        values.extend(
            bytes[8..]
                .chunks(8)
                .map(|c| f64::from_le_bytes(c.try_into().unwrap())),
        );
    }
    values
}

fn decode_base64(text: &str) -> Vec<u8> {
    let value = |c: u8| match c {
        b'A'..=b'Z' => c - b'A',
        b'a'..=b'z' => c - b'a' + 26,
        b'0'..=b'9' => c - b'0' + 52,
        b'+' => 62,
        b'/' => 63,
        _ => panic!("not base64: {c}"),
    };
    let mut out = Vec::new();
    for chunk in text.as_bytes().chunks(4) {
        let pad = chunk.iter().filter(|&&c| c == b'=').count();
        let n = chunk
            .iter()
            .take(4 - pad)
            .enumerate()
            .fold(0u32, |n, (i, &c)| n | (value(c) as u32) << (18 - 6 * i));
        out.extend_from_slice(&n.to_be_bytes()[1..4 - pad]);
    }
    out
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
    assert!(
        err.contains("s.toml:4:") && err.contains("no vertices"),
        "{err}"
    );
}
