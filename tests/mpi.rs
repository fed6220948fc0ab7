//! `mpirun -n N tetsim run` (feature `mpi`) gives the serial run's answers and files: a held-out
//! dynamic cantilever on 1, 2 and 4 ranks (oversubscribed on a 2-core machine), a held-out
//! static one against the serial run and beam theory, each rank holding only its part, and
//! METIS's partitions against coordinate bisection. Needs Debian's `openmpi-bin libopenmpi-dev
//! libpetsc-real-dev libmetis-dev libclang-dev`; run with
//! `cargo test --release --features mpi --test mpi`.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use tetsim::math::Vec3;

fn scene() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/mpi/cantilever.toml")
}

fn static_scene() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/mpi/cantilever_static.toml")
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
        .env("TETSIM_MPI_STATS", "1")
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

/// The largest distance between the same vertex in two frames, m.
fn farthest(a: &[Vec3], b: &[Vec3]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(a, b)| (a - b).norm())
        .fold(0.0, f64::max)
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
    let moved = farthest(&positions(&serial, 0), &positions(&serial, 4));
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
            let worst = farthest(&positions(&serial, frame), &positions(&dir, frame));
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

/// BDF2 and Newmark keep their history on every rank: 2 ranks give the serial answer.
#[test]
fn every_time_scheme_gives_the_serial_answer_on_two_ranks() {
    let tmp = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(scene()).unwrap();
    for scheme in ["bdf2", "newmark"] {
        let path = tmp.path().join(format!("{scheme}.toml"));
        let with = text.replace(
            "[solver]\n",
            &format!("[solver]\nintegrator = \"{scheme}\"\n"),
        );
        assert_ne!(with, text);
        std::fs::write(&path, with).unwrap();
        let serial = tmp.path().join(format!("{scheme}-serial"));
        let out = run(None, &path, &serial);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let dir = tmp.path().join(format!("{scheme}-ranks"));
        let out = run(Some(2), &path, &dir);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let moved = farthest(&positions(&serial, 0), &positions(&serial, 4));
        for frame in 1..=4 {
            let worst = farthest(&positions(&serial, frame), &positions(&dir, frame));
            assert!(
                worst <= 1e-5 * moved,
                "{scheme}, frame {frame}: {worst:e} m apart (moved {moved:e} m)"
            );
        }
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

/// Each rank's `mpi stats` line: (rank, tets, owned, ghosts, setup bytes received).
fn rank_stats(stderr: &str) -> Vec<[usize; 5]> {
    let field = |line: &str, name: &str| -> usize {
        let at = line.find(&format!("{name}: ")).expect(name) + name.len() + 2;
        line[at..]
            .split(|c: char| !c.is_ascii_digit())
            .next()
            .unwrap()
            .parse()
            .unwrap()
    };
    // Split at the marker, not at line ends: mpirun may put two ranks' lines on one.
    let mut all: Vec<[usize; 5]> = stderr
        .split("mpi stats:")
        .skip(1)
        .map(|l| {
            [
                field(l, "rank"),
                field(l, "tets"),
                field(l, "owned"),
                field(l, "ghosts"),
                field(l, "setup_bytes"),
            ]
        })
        .collect();
    all.sort();
    all
}

/// The held-out static cantilever (E = 1 MPa, ν = 0.3, 4 × 0.4 × 0.4 m, 0.4 N at the tip) on 2
/// ranks: the serial answer, and beam theory's tip deflection F·L³/(3EI) + F·L/(κGA) within
/// the stiffness linear tets are known for in bending at 4 cells through the depth.
#[test]
fn a_static_cantilever_matches_serial_and_beam_theory() {
    let tmp = tempfile::tempdir().unwrap();
    let serial = tmp.path().join("serial");
    let out = run(None, &static_scene(), &serial);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let parallel = tmp.path().join("two");
    let out = run(Some(2), &static_scene(), &parallel);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let rest = positions(&serial, 0);
    let (a, b) = (positions(&serial, 1), positions(&parallel, 1));
    let tip = |x: &[Vec3]| {
        let tips: Vec<f64> = rest
            .iter()
            .zip(x)
            .filter(|(r, _)| r.x > 3.99)
            .map(|(r, x)| x.y - r.y)
            .collect();
        tips.iter().sum::<f64>() / tips.len() as f64
    };
    let (e, nu, l, h, f) = (1.0e6, 0.3, 4.0, 0.4, 0.4);
    let i = h * h * h * h / 12.0;
    let g = e / (2.0 * (1.0 + nu));
    let beam = f * l * l * l / (3.0 * e * i) + f * l / (5.0 / 6.0 * g * h * h);
    let (ts, tp) = (-tip(&a), -tip(&b));
    assert!(
        (ts - tp).abs() <= 1e-6 * ts,
        "tip deflection: serial {ts:e} m, 2 ranks {tp:e} m"
    );
    let worst = a
        .iter()
        .zip(&b)
        .map(|(a, b)| (a - b).norm())
        .fold(0.0, f64::max);
    assert!(worst <= 1e-6 * ts, "2 ranks {worst:e} m from serial");
    // Linear tets, 4 elements through the depth: stiffer than the beam, by a known amount.
    let ratio = tp / beam;
    eprintln!("tip deflection {tp:e} m, beam theory {beam:e} m, ratio {ratio:.3}");
    assert!(
        (0.75..=1.02).contains(&ratio),
        "tip deflection {tp:e} m against beam theory's {beam:e} m (ratio {ratio:.3})"
    );
}

/// Each rank holds its part only: its tets, owned and ghost vertices and the set-up it
/// receives shrink as ranks are added (memory per rank, measured in docs/scaling.md).
#[test]
fn each_rank_holds_only_its_part() {
    let tmp = tempfile::tempdir().unwrap();
    let mut largest = Vec::new();
    for ranks in [1, 2, 4] {
        let out = run(
            Some(ranks),
            &static_scene(),
            &tmp.path().join(format!("r{ranks}")),
        );
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{err}");
        let stats = rank_stats(&err);
        assert_eq!(stats.len(), ranks, "{err}");
        let tets: usize = stats.iter().map(|s| s[1]).sum();
        let owned: usize = stats.iter().map(|s| s[2]).sum();
        assert_eq!(tets, 3840, "every tet on one rank");
        assert_eq!(owned, 41 * 5 * 5, "every vertex owned once");
        // The largest part (tets, vertices held, bytes received by a rank other than 0).
        let held = stats.iter().map(|s| s[2] + s[3]).max().unwrap();
        let most_tets = stats.iter().map(|s| s[1]).max().unwrap();
        let received = stats.iter().skip(1).map(|s| s[4]).max().unwrap_or(0);
        largest.push((ranks, most_tets, held, received));
    }
    for pair in largest.windows(2) {
        let ((r0, t0, h0, _), (r1, t1, h1, b1)) = (pair[0], pair[1]);
        assert!(t1 * r1 <= t0 * r0 * 21 / 20, "tets per rank: {largest:?}");
        assert!(h1 < h0, "vertices per rank fall: {largest:?}");
        if r1 > 2 {
            assert!(b1 < pair[0].3, "set-up bytes per rank fall: {largest:?}");
        }
    }
}

/// METIS's dual-graph partition against recursive coordinate bisection of the centroids: the
/// ghost layers (what the halo exchanges send) on real meshes from Gmsh and TetGen.
#[test]
fn metis_cuts_no_more_than_bisection() {
    use tetsim::parallel::partition::Partition;
    let fixtures = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures");
    let mut worse = Vec::new();
    for name in ["ball.node", "torus.vtu", "beam_v41.msh"] {
        let mesh = tetsim::io::read_mesh(&fixtures.join(name)).unwrap().mesh;
        for parts in [2, 4, 8, 16] {
            let rcb = Partition::new(&mesh, parts).ghost_count(&mesh);
            let (tet_part, _) =
                tetsim::parallel::metis::partition_tets(mesh.positions.len(), &mesh.tets, parts)
                    .unwrap();
            let again =
                tetsim::parallel::metis::partition_tets(mesh.positions.len(), &mesh.tets, parts)
                    .unwrap()
                    .0;
            assert_eq!(tet_part, again, "METIS is deterministic");
            let metis = Partition::from_tet_parts(&mesh, parts, tet_part).ghost_count(&mesh);
            eprintln!("{name} {parts} parts: ghosts rcb {rcb}, metis {metis}");
            if metis > rcb {
                worse.push((name, parts, rcb, metis));
            }
        }
    }
    // Measured: 7–23 % fewer ghosts than bisection on every mesh and part count.
    assert!(
        worse.is_empty(),
        "METIS's halo larger than bisection's: {worse:?}"
    );
}
