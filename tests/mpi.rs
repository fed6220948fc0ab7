//! `mpirun -n N tetsim run` (feature `mpi`) gives the serial run's answers and files: a held-out
//! cantilever on 1, 2 and 4 ranks (oversubscribed on a 2-core machine). Needs Debian's
//! `openmpi-bin libopenmpi-dev libpetsc-real-dev libclang-dev`; run with
//! `cargo test --release --features mpi --test mpi`.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use tetsim::math::Vec3;

fn scene() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/mpi/cantilever.toml")
}

/// `tetsim run SCENE --out DIR` on `ranks` MPI ranks (None: plain, serial).
fn run(ranks: Option<usize>, scene: &Path, out: &Path) -> Output {
    let bin = env!("CARGO_BIN_EXE_tetsim");
    let mut cmd = match ranks {
        None => Command::new(bin),
        Some(n) => {
            let mut c = Command::new("mpirun");
            c.args(["--oversubscribe", "-n", &n.to_string(), bin]);
            c
        }
    };
    cmd.arg("run")
        .arg(scene)
        .arg("--out")
        .arg(out)
        .arg("--deterministic")
        // Open MPI refuses root unless told (CI runs as root).
        .env("OMPI_ALLOW_RUN_AS_ROOT", "1")
        .env("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1")
        .env("OMPI_MCA_rmaps_base_oversubscribe", "1")
        .output()
        .expect("mpirun and tetsim run")
}

fn files(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

fn positions(dir: &Path, frame: usize) -> Vec<Vec3> {
    tetsim::io::vtu::read_vtu_frame(&dir.join(format!("frame_{frame:04}.vtu")))
        .unwrap()
        .points
}

#[test]
fn ranks_give_the_serial_answer_and_files() {
    let tmp = tempfile::tempdir().unwrap();
    let serial = tmp.path().join("serial");
    let out = run(None, &scene(), &serial);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let rest = positions(&serial, 0);
    let end = positions(&serial, 4);
    let moved = rest
        .iter()
        .zip(&end)
        .map(|(a, b)| (a - b).norm())
        .fold(0.0, f64::max);
    assert!(moved > 1e-3, "the beam moves ({moved:e} m)");
    for ranks in [1, 2, 4] {
        let dir = tmp.path().join(format!("ranks{ranks}"));
        let out = run(Some(ranks), &scene(), &dir);
        assert!(
            out.status.success(),
            "{ranks} ranks: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        assert_eq!(files(&dir), files(&serial), "{ranks} ranks: the same files");
        for frame in 1..=4 {
            let (a, b) = (positions(&serial, frame), positions(&dir, frame));
            let worst = a
                .iter()
                .zip(&b)
                .map(|(a, b)| (a - b).norm())
                .fold(0.0, f64::max);
            // Newton stops at 1e-7 of the first residual: the answers agree far below the
            // displacement (the serial AMG and PETSc's GAMG stop at different iterates).
            assert!(
                worst <= 1e-5 * moved,
                "{ranks} ranks, frame {frame}: {worst:e} m apart (moved {moved:e} m)"
            );
        }
        let csv = std::fs::read_to_string(dir.join("steps.csv")).unwrap();
        let converged = csv
            .lines()
            .skip(1)
            .all(|l| l.split(',').nth(5) == Some("true"));
        assert!(converged, "{ranks} ranks: every frame converged\n{csv}");
    }
}

#[test]
fn obstacles_are_refused_under_mpirun() {
    let tmp = tempfile::tempdir().unwrap();
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/ball_bowl.toml");
    let out = run(Some(2), &scene, &tmp.path().join("out"));
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("contact is not distributed"), "{err}");
}
