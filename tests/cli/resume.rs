//! Stopping and resuming (SPEC §14), and an output folder that never mixes two runs: the real
//! binary killed (SIGKILL), interrupted (SIGINT) and resumed.

use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use super::{stderr, tetsim};

pub(super) fn spawn(dir: &Path, args: &[&str]) -> Child {
    Command::new(env!("CARGO_BIN_EXE_tetsim"))
        .args(args)
        .current_dir(dir)
        .env("RUST_LOG", "warn")
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("the tetsim binary starts")
}

/// Wait until `file` exists (the run is at least that far), then return at once.
pub(super) fn wait_for(child: &mut Child, file: &Path) {
    let started = Instant::now();
    while !file.exists() {
        if let Some(status) = child.try_wait().unwrap() {
            panic!(
                "the run ended ({status}) before {} appeared",
                file.display()
            );
        }
        assert!(started.elapsed() < Duration::from_secs(300), "timed out");
        std::thread::sleep(Duration::from_millis(1));
    }
}

pub(super) fn signal(child: &Child, name: &str) {
    let ok = Command::new("kill")
        .args([&format!("-{name}"), &child.id().to_string()])
        .status()
        .unwrap()
        .success();
    assert!(ok, "kill -{name}");
}

pub(super) fn manifest(dir: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(dir.join("manifest.json")).unwrap()).unwrap()
}

/// Every file of the run but timings.csv (wall-clock times) and the checkpoint, by name.
pub(super) fn results(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut files: Vec<(String, Vec<u8>)> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| {
            let name = p.file_name().unwrap().to_string_lossy();
            name != "timings.csv" && name != "checkpoint.bin" && name != "manifest.json"
        })
        .map(|p| {
            let name = p.file_name().unwrap().to_string_lossy().into_owned();
            (name, std::fs::read(&p).unwrap())
        })
        .collect();
    files.sort();
    files
}

#[test]
fn killed_twice_and_resumed_writes_the_bytes_of_a_run_never_stopped() {
    let dir = tempfile::tempdir().unwrap();
    let args = ["run", "--frames", "24", "--deterministic", "--no-pictures"];
    let whole = tetsim(dir.path(), &[&args[..], &["--out", "whole"]].concat());
    assert!(whole.status.success(), "{}", stderr(&whole));

    let run = dir.path().join("stopped");
    let mut child = spawn(dir.path(), &[&args[..], &["--out", "stopped"]].concat());
    wait_for(&mut child, &run.join("frame_0007.vtu"));
    child.kill().unwrap(); // SIGKILL: no chance to tidy up
    child.wait().unwrap();
    assert_eq!(manifest(&run)["status"], "running");

    let mut child = spawn(dir.path(), &["run", "--resume", "stopped"]);
    wait_for(&mut child, &run.join("frame_0016.vtu"));
    child.kill().unwrap();
    child.wait().unwrap();

    let last = tetsim(dir.path(), &["run", "--resume", "stopped"]);
    assert!(last.status.success(), "{}", stderr(&last));
    let (a, b) = (results(&dir.path().join("whole")), results(&run));
    assert_eq!(
        a.iter().map(|f| &f.0).collect::<Vec<_>>(),
        b.iter().map(|f| &f.0).collect::<Vec<_>>()
    );
    for ((name, x), (_, y)) in a.iter().zip(&b) {
        assert!(x == y, "{name} differs from the run never stopped");
    }
    let (ma, mb) = (manifest(&dir.path().join("whole")), manifest(&run));
    assert_eq!(mb["status"], "complete");
    assert_eq!(ma["outputs"], mb["outputs"]);
    assert_eq!(ma["parameters"], mb["parameters"]);
    assert_eq!(mb["output_dir"], "stopped");
}

#[test]
fn ctrl_c_finishes_the_frame_and_says_how_to_resume() {
    let dir = tempfile::tempdir().unwrap();
    let run = dir.path().join("out");
    let mut child = spawn(
        dir.path(),
        &["run", "--frames", "40", "--no-pictures", "--out", "out"],
    );
    wait_for(&mut child, &run.join("frame_0003.vtu"));
    assert_eq!(manifest(&run)["status"], "running");
    signal(&child, "INT");
    let out = child.wait_with_output().unwrap();
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(130), "{err}");
    assert!(
        err.contains("resume with: tetsim run --resume out"),
        "{err}"
    );
    let m = manifest(&run);
    assert_eq!(m["status"], "interrupted");
    let frame = m["frame"].as_u64().unwrap() as usize;
    assert!((3..40).contains(&frame), "{m}");
    // Every frame up to the one reached, and nothing after it.
    assert!(run.join(format!("frame_{frame:04}.vtu")).exists());
    assert!(!run.join(format!("frame_{:04}.vtu", frame + 1)).exists());
    let rows = std::fs::read_to_string(run.join("steps.csv")).unwrap();
    assert_eq!(
        rows.lines().count(),
        frame + 2,
        "header and frames 0..={frame}"
    );

    // Resumed and taken further than it was started for.
    let out = tetsim(dir.path(), &["run", "--resume", "out", "--frames", "42"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let m = manifest(&run);
    assert_eq!(m["status"], "complete");
    assert_eq!(m["frame"], 42);
    let rows = std::fs::read_to_string(run.join("steps.csv")).unwrap();
    assert_eq!(rows.lines().count(), 44);
}

#[test]
fn sigterm_exits_143_with_an_interrupted_manifest() {
    let dir = tempfile::tempdir().unwrap();
    let run = dir.path().join("out");
    let mut child = spawn(
        dir.path(),
        &["run", "--frames", "40", "--no-pictures", "--out", "out"],
    );
    wait_for(&mut child, &run.join("frame_0002.vtu"));
    signal(&child, "TERM");
    let out = child.wait_with_output().unwrap();
    assert_eq!(out.status.code(), Some(143), "{}", stderr(&out));
    assert_eq!(manifest(&run)["status"], "interrupted");
}

#[test]
fn a_shorter_rerun_leaves_no_frames_of_the_earlier_run() {
    let dir = tempfile::tempdir().unwrap();
    let long = tetsim(dir.path(), &["run", "--frames", "6", "--out", "out"]);
    assert!(long.status.success(), "{}", stderr(&long));
    std::fs::write(dir.path().join("out/notes.txt"), "mine").unwrap();
    let short = tetsim(
        dir.path(),
        &["run", "--frames", "2", "--out", "out", "--no-pictures"],
    );
    assert!(short.status.success(), "{}", stderr(&short));
    assert!(
        stderr(&short).contains("removed") && stderr(&short).contains("earlier run"),
        "{}",
        stderr(&short)
    );
    let out = dir.path().join("out");
    assert!(out.join("frame_0002.vtu").exists());
    for gone in [
        "frame_0003.vtu",
        "surface_0006.obj",
        "animation.gif",
        "preview.png",
    ] {
        assert!(
            !out.join(gone).exists(),
            "{gone} of the earlier run is left"
        );
    }
    assert!(
        out.join("notes.txt").exists(),
        "a file not ours was removed"
    );
    let m = manifest(&out);
    assert_eq!(m["status"], "complete");
    assert_eq!(m["frame"], 2);
    assert_eq!(m["outputs"]["frames"].as_array().unwrap().len(), 3);
}

#[test]
fn a_corrupted_checkpoint_another_version_or_none_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let out = tetsim(
        dir.path(),
        &["run", "--frames", "2", "--no-pictures", "--out", "out"],
    );
    assert!(out.status.success(), "{}", stderr(&out));
    let path = dir.path().join("out/checkpoint.bin");
    let good = std::fs::read(&path).unwrap();

    let mut bad = good.clone();
    let k = bad.len() / 2;
    bad[k] ^= 1;
    std::fs::write(&path, &bad).unwrap();
    let out = tetsim(dir.path(), &["run", "--resume", "out", "--frames", "3"]);
    assert_eq!(out.status.code(), Some(1));
    assert!(stderr(&out).contains("corrupted"), "{}", stderr(&out));

    let mut other = good.clone();
    other[8] = 200; // the format version
    std::fs::write(&path, &other).unwrap();
    let out = tetsim(dir.path(), &["run", "--resume", "out", "--frames", "3"]);
    assert_eq!(out.status.code(), Some(1));
    assert!(stderr(&out).contains("format 200"), "{}", stderr(&out));

    std::fs::create_dir(dir.path().join("empty")).unwrap();
    let out = tetsim(dir.path(), &["run", "--resume", "empty"]);
    assert_eq!(out.status.code(), Some(1));
    assert!(
        stderr(&out).contains("there is no checkpoint"),
        "{}",
        stderr(&out)
    );

    std::fs::write(&path, &good).unwrap();
    let out = tetsim(dir.path(), &["run", "--resume", "out", "--frames", "3"]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(dir.path().join("out/frame_0003.vtu").exists());
}

#[test]
fn resume_counts_the_whole_run_says_when_complete_and_refuses_a_lost_frame() {
    let dir = tempfile::tempdir().unwrap();
    let run = |args: &[&str]| tetsim(dir.path(), args);
    let out = run(&["run", "--frames", "3", "--no-pictures", "--out", "out"]);
    assert!(out.status.success(), "{}", stderr(&out));

    // Finished: said so, nothing recomputed, exit 0.
    let before = std::fs::read(dir.path().join("out/steps.csv")).unwrap();
    let out = run(&["run", "--resume", "out"]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(
        stderr(&out).contains("already complete (3 frames"),
        "{}",
        stderr(&out)
    );
    assert_eq!(
        std::fs::read(dir.path().join("out/steps.csv")).unwrap(),
        before
    );

    // Going on: progress lines count frames of the whole run.
    let out = run(&["run", "--resume", "out", "--frames", "5"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let err = stderr(&out);
    assert!(err.contains("after frame 3 of 5"), "{err}");
    assert!(err.contains("frame 4/5"), "{err}");

    // An earlier frame edited, then deleted: refused with the frame named, nothing written.
    let frame = dir.path().join("out/frame_0002.vtu");
    let mut bytes = std::fs::read(&frame).unwrap();
    bytes.push(b'\n');
    std::fs::write(&frame, &bytes).unwrap();
    let out = run(&["run", "--resume", "out", "--frames", "6"]);
    assert_eq!(out.status.code(), Some(1), "{}", stderr(&out));
    assert!(
        stderr(&out).contains("frame 2 was changed"),
        "{}",
        stderr(&out)
    );
    std::fs::remove_file(&frame).unwrap();
    let out = run(&["run", "--resume", "out", "--frames", "6"]);
    assert_eq!(out.status.code(), Some(1), "{}", stderr(&out));
    assert!(
        stderr(&out).contains("frame_0002.vtu: frame 2 is missing"),
        "{}",
        stderr(&out)
    );
    assert!(!dir.path().join("out/frame_0006.vtu").exists());
}

#[test]
fn bad_picture_settings_fail_before_the_first_frame() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("s.toml"),
        "[mesh]\ngenerator = { box = { min = [0,0,0], max = [1,1,1], cells = [2,2,2] } }\n\
         [output]\ngif_width = 20000\ndir = \"out\"\n",
    )
    .unwrap();
    let out = tetsim(dir.path(), &["run", "s.toml", "--frames", "3"]);
    assert_eq!(out.status.code(), Some(1));
    assert!(stderr(&out).contains("gif_width"), "{}", stderr(&out));
    assert!(!dir.path().join("out/frame_0001.vtu").exists());
}

#[test]
fn a_picture_that_cannot_be_written_costs_the_pictures_not_the_run() {
    let dir = tempfile::tempdir().unwrap();
    let out_dir = dir.path().join("out");
    // A folder where preview.png should go: the picture cannot be written.
    std::fs::create_dir_all(out_dir.join("preview.png")).unwrap();
    let out = tetsim(dir.path(), &["run", "--frames", "3", "--out", "out"]);
    assert_eq!(out.status.code(), Some(1));
    assert!(stderr(&out).contains("pictures"), "{}", stderr(&out));
    let m = manifest(&out_dir);
    assert_eq!(m["status"], "complete");
    assert!(
        m["problems"][0].as_str().unwrap().contains("pictures"),
        "{m}"
    );
    let rows = std::fs::read_to_string(out_dir.join("steps.csv")).unwrap();
    assert_eq!(rows.lines().count(), 5);
}

#[test]
fn probes_and_reactions_continue_after_a_kill_and_go_with_a_new_run() {
    // SPEC §13 files under SPEC §14: a run killed and resumed writes the probes.csv and
    // reactions.csv of a run never stopped (a row written after the checkpoint is written again).
    let dir = tempfile::tempdir().unwrap();
    let scene = tetsim::scene::DEFAULT_SCENE
        .replace(
            "[[fixed]]\n",
            "[[probe]]\nname = \"tip\"\npoint = [\"4 m\", \"500 mm\", 0.5]\n\n[[fixed]]\nname = \"clamp\"\n",
        )
        .replace("dir = \"out\"", "dir = \"whole\"");
    assert!(scene.contains("name = \"clamp\""));
    std::fs::write(dir.path().join("s.toml"), &scene).unwrap();
    let args = [
        "run",
        "s.toml",
        "--frames",
        "20",
        "--deterministic",
        "--no-pictures",
    ];
    let whole = tetsim(dir.path(), &[&args[..], &["--out", "whole"]].concat());
    assert!(whole.status.success(), "{}", stderr(&whole));

    let run = dir.path().join("stopped");
    let mut child = spawn(dir.path(), &[&args[..], &["--out", "stopped"]].concat());
    wait_for(&mut child, &run.join("frame_0006.vtu"));
    child.kill().unwrap();
    child.wait().unwrap();
    assert_eq!(manifest(&run)["status"], "running");
    let last = tetsim(dir.path(), &["run", "--resume", "stopped"]);
    assert!(last.status.success(), "{}", stderr(&last));
    let whole_dir = dir.path().join("whole");
    for name in ["probes.csv", "reactions.csv", "steps.csv"] {
        let a = std::fs::read(whole_dir.join(name)).unwrap();
        let b = std::fs::read(run.join(name)).unwrap();
        assert!(a == b, "{name} differs from the run never stopped");
        assert_eq!(String::from_utf8_lossy(&a).lines().count(), 22, "{name}");
    }
    let m = manifest(&run);
    assert!(m["outputs"]["files"]["probes.csv"].is_string(), "{m}");
    assert_eq!(m["outputs"], manifest(&whole_dir)["outputs"]);

    // A run without probes in the same folder leaves no probes.csv of the earlier one.
    let plain = tetsim(
        dir.path(),
        &["run", "--frames", "2", "--out", "whole", "--no-pictures"],
    );
    assert!(plain.status.success(), "{}", stderr(&plain));
    assert!(!whole_dir.join("probes.csv").exists());
    assert!(!whole_dir.join("reactions.csv").exists());
}

#[test]
fn a_run_resumed_while_elements_are_tangled_writes_the_bytes_of_one_never_stopped() {
    // The tangled-element flags and the recovery form in use are in the checkpoint: stopped
    // after frame 1 of a cube flattened onto a plane (every element tangled, the collapsed form)
    // and resumed, the run goes on exactly as one never stopped (the forms change at frame 2).
    let dir = tempfile::tempdir().unwrap();
    let scenes = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    std::fs::create_dir(dir.path().join("meshes")).unwrap();
    std::fs::copy(
        scenes.join("meshes/cube_flattened.txt"),
        dir.path().join("meshes/cube_flattened.txt"),
    )
    .unwrap();
    std::fs::copy(
        scenes.join("squash_recover.toml"),
        dir.path().join("s.toml"),
    )
    .unwrap();
    let args = ["run", "s.toml", "--deterministic", "--no-pictures", "-q"];
    let whole = tetsim(
        dir.path(),
        &[&args[..], &["--frames", "5", "--out", "whole"]].concat(),
    );
    assert!(whole.status.success(), "{}", stderr(&whole));
    let part = tetsim(
        dir.path(),
        &[&args[..], &["--frames", "1", "--out", "part"]].concat(),
    );
    assert!(part.status.success(), "{}", stderr(&part));
    let rest = tetsim(
        dir.path(),
        &["run", "--resume", "part", "--frames", "5", "-q"],
    );
    assert!(rest.status.success(), "{}", stderr(&rest));
    let steps = std::fs::read_to_string(dir.path().join("whole/steps.csv")).unwrap();
    let tangled: Vec<&str> = steps
        .lines()
        .skip(1)
        .map(|l| l.rsplit(',').next().unwrap())
        .collect();
    assert_eq!(tangled[1], "1296", "{steps}");
    assert_eq!(tangled[5], "0", "{steps}");
    for name in ["steps.csv", "frame_0005.vtu", "frame_0002.vtu"] {
        let a = std::fs::read(dir.path().join("whole").join(name)).unwrap();
        let b = std::fs::read(dir.path().join("part").join(name)).unwrap();
        assert!(a == b, "{name} differs from the run never stopped");
    }
}

/// A signal stops the frame being computed, not only the frame loop: a cube dropped at
/// 1,000 m/s spends minutes in its first frame (every retry capped), and SIGTERM ends the run
/// inside it, keeping frame 0 and dropping frame 1.
#[test]
fn sigterm_inside_a_long_frame_stops_it_and_drops_it() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("fast.toml"),
        r#"
        gravity = [0.0, -9.81, 0.0]
        [mesh]
        generator = { box = { min = [-0.5, 0.5, -0.5], max = [0.5, 1.5, 0.5], cells = [3, 3, 3] } }
        [material]
        youngs_modulus = 1e5
        poisson_ratio = 0.3
        [initial]
        velocity = [0.0, -1000.0, 0.0]
        [[obstacle]]
        plane = { point = [0, 0, 0], normal = [0, 1, 0] }
        [solver]
        dt = 0.01
        frames = 5
        "#,
    )
    .unwrap();
    let run = dir.path().join("out");
    let mut child = spawn(
        dir.path(),
        &["run", "fast.toml", "--no-pictures", "--out", "out"],
    );
    wait_for(&mut child, &run.join("checkpoint.bin"));
    std::thread::sleep(Duration::from_millis(500));
    signal(&child, "TERM");
    // Frame 1 alone takes minutes (over a minute in a release build); a stop that waited for
    // it would not come within this guard.
    let started = Instant::now();
    while child.try_wait().unwrap().is_none() {
        if started.elapsed() > Duration::from_secs(60) {
            child.kill().unwrap();
            panic!("SIGTERM did not stop the frame within 60 s");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    let out = child.wait_with_output().unwrap();
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(143), "{err}");
    assert!(err.contains("interrupted (SIGTERM) after frame 0"), "{err}");
    let m = manifest(&run);
    assert_eq!(m["status"], "interrupted");
    assert_eq!(m["frame"], 0);
    assert!(run.join("frame_0000.vtu").exists());
    assert!(!run.join("frame_0001.vtu").exists());
    let rows = std::fs::read_to_string(run.join("steps.csv")).unwrap();
    assert_eq!(rows.lines().count(), 2, "header and frame 0: {rows}");
}

/// Each time scheme keeps its history in the checkpoint (BDF2 the step before, Newmark the
/// acceleration, the audit's damping forces): a block dropped on the ground, stopped after
/// frame 4 (in contact) and resumed, writes the bytes of a run never stopped.
#[test]
fn a_resumed_run_of_every_time_scheme_writes_the_bytes_of_one_never_stopped() {
    for scheme in ["bdf2", "newmark"] {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(
            dir.path().join("s.toml"),
            format!(
                r#"
                gravity = [0.0, -9.81, 0.0]
                [mesh]
                generator = {{ box = {{ min = [0, 0.02, 0], max = [0.2, 0.12, 0.2], cells = [3, 2, 3] }} }}
                [material]
                youngs_modulus = 1e5
                density = 1000
                [[obstacle]]
                plane = {{ point = [0, 0, 0], normal = [0, 1, 0] }}
                friction = 0.3
                [initial]
                velocity = [0.3, 0.0, 0.0]
                [solver]
                integrator = "{scheme}"
                dt = 0.02
                frames = 14
                rayleigh_stiffness = 0.002
                "#
            ),
        )
        .unwrap();
        let args = ["run", "s.toml", "--deterministic", "--no-pictures", "-q"];
        let whole = tetsim(dir.path(), &[&args[..], &["--out", "whole"]].concat());
        assert!(whole.status.success(), "{scheme}: {}", stderr(&whole));
        let part = tetsim(
            dir.path(),
            &[&args[..], &["--frames", "4", "--out", "part"]].concat(),
        );
        assert!(part.status.success(), "{scheme}: {}", stderr(&part));
        let rest = tetsim(
            dir.path(),
            &["run", "--resume", "part", "--frames", "14", "-q"],
        );
        assert!(rest.status.success(), "{scheme}: {}", stderr(&rest));
        // The stop falls inside the contact: the block is on the ground at frame 4.
        let steps = std::fs::read_to_string(dir.path().join("whole/steps.csv")).unwrap();
        let header: Vec<&str> = steps.lines().next().unwrap().split(',').collect();
        let column = header.iter().position(|h| *h == "contacts").unwrap();
        let contacts: u64 = steps
            .lines()
            .nth(5)
            .unwrap()
            .split(',')
            .nth(column)
            .unwrap()
            .parse()
            .unwrap();
        assert!(contacts > 0, "{scheme}: no contact at frame 4\n{steps}");
        let (a, b) = (
            results(&dir.path().join("whole")),
            results(&dir.path().join("part")),
        );
        assert_eq!(a.len(), b.len(), "{scheme}");
        for ((name, x), (_, y)) in a.iter().zip(&b) {
            assert!(
                x == y,
                "{scheme}: {name} differs from the run never stopped"
            );
        }
    }
}
