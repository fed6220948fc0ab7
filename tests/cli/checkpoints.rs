//! Checkpoints at a bounded cost (`[output] checkpoint_every`, `checkpoint_frames`; SPEC §14)
//! and output written beside the frame loop: a run stopped and resumed still writes the bytes of
//! a run never stopped, the checkpoint is not rewritten every frame, Ctrl-C and the end still
//! checkpoint the last frame, and a file that cannot be written ends the run naming it.

use std::path::Path;

use tetsim::checkpoint::{Checkpoint, FILE_NAME};

use super::resume::{manifest, results, signal, spawn, wait_for};
use super::{stderr, tetsim};

/// The default scene with `keys` added to its [output], as `s.toml` in `dir`.
fn scene_with(dir: &Path, keys: &str) {
    let text =
        tetsim::scene::DEFAULT_SCENE.replace("dir = \"out\"", &format!("dir = \"out\"\n{keys}"));
    assert!(text.contains(keys));
    std::fs::write(dir.join("s.toml"), text).unwrap();
}

fn checkpoint_frame(dir: &Path) -> usize {
    Checkpoint::read(&dir.join(FILE_NAME))
        .unwrap()
        .simulation
        .frame
}

/// Kill (SIGKILL) a run of s.toml into `name` once `frame` is written, then resume it to its end.
fn killed_at(dir: &Path, name: &str, frame: usize) -> usize {
    let args = [
        "run",
        "s.toml",
        "--frames",
        "24",
        "--deterministic",
        "--no-pictures",
    ];
    let mut child = spawn(dir, &[&args[..], &["--out", name]].concat());
    wait_for(
        &mut child,
        &dir.join(name).join(format!("frame_{frame:04}.vtu")),
    );
    child.kill().unwrap();
    child.wait().unwrap();
    checkpoint_frame(&dir.join(name))
}

fn assert_same_files(a: &Path, b: &Path) {
    let (a, b) = (results(a), results(b));
    assert_eq!(
        a.iter().map(|f| &f.0).collect::<Vec<_>>(),
        b.iter().map(|f| &f.0).collect::<Vec<_>>()
    );
    for ((name, x), (_, y)) in a.iter().zip(&b) {
        assert!(x == y, "{name} differs from the run never stopped");
    }
}

#[test]
fn a_run_checkpointed_hourly_resumes_from_frame_0_to_the_same_bytes() {
    let dir = tempfile::tempdir().unwrap();
    scene_with(dir.path(), "checkpoint_every = \"3600 s\"");
    let args = [
        "run",
        "s.toml",
        "--frames",
        "24",
        "--deterministic",
        "--no-pictures",
    ];
    let whole = tetsim(dir.path(), &[&args[..], &["--out", "whole"]].concat());
    assert!(whole.status.success(), "{}", stderr(&whole));
    // Written at the end whatever the interval.
    assert_eq!(checkpoint_frame(&dir.path().join("whole")), 24);

    // Killed at frame 9 or later: the checkpoint is still frame 0's.
    assert_eq!(killed_at(dir.path(), "stopped", 9), 0);
    let run = dir.path().join("stopped");
    assert_eq!(manifest(&run)["status"], "running");
    let last = tetsim(dir.path(), &["run", "--resume", "stopped"]);
    assert!(last.status.success(), "{}", stderr(&last));
    assert_same_files(&dir.path().join("whole"), &run);
    let (ma, mb) = (manifest(&dir.path().join("whole")), manifest(&run));
    assert_eq!(mb["status"], "complete");
    assert_eq!(ma["outputs"], mb["outputs"]);
}

#[test]
fn checkpoint_frames_checkpoints_every_kth_frame_and_resumes_to_the_same_bytes() {
    let dir = tempfile::tempdir().unwrap();
    scene_with(
        dir.path(),
        "checkpoint_every = \"3600 s\"\ncheckpoint_frames = 5",
    );
    let args = [
        "run",
        "s.toml",
        "--frames",
        "24",
        "--deterministic",
        "--no-pictures",
    ];
    let whole = tetsim(dir.path(), &[&args[..], &["--out", "whole"]].concat());
    assert!(whole.status.success(), "{}", stderr(&whole));

    // Frame 12 written: frame 10's checkpoint was written before frame 11's files.
    let frame = killed_at(dir.path(), "stopped", 12);
    assert!(
        frame.is_multiple_of(5) && frame >= 10,
        "checkpoint of frame {frame}"
    );
    let last = tetsim(dir.path(), &["run", "--resume", "stopped"]);
    assert!(last.status.success(), "{}", stderr(&last));
    assert_same_files(&dir.path().join("whole"), &dir.path().join("stopped"));
}

#[test]
fn ctrl_c_checkpoints_the_last_frame_whatever_the_interval() {
    let dir = tempfile::tempdir().unwrap();
    scene_with(dir.path(), "checkpoint_every = \"3600 s\"");
    let run = dir.path().join("out");
    let mut child = spawn(
        dir.path(),
        &[
            "run",
            "s.toml",
            "--frames",
            "400",
            "--no-pictures",
            "--out",
            "out",
        ],
    );
    wait_for(&mut child, &run.join("frame_0005.vtu"));
    signal(&child, "INT");
    let out = child.wait_with_output().unwrap();
    assert_eq!(out.status.code(), Some(130), "{}", stderr(&out));
    let m = manifest(&run);
    assert_eq!(m["status"], "interrupted");
    let frame = m["frame"].as_u64().unwrap() as usize;
    assert!(frame >= 5, "{m}");
    assert_eq!(checkpoint_frame(&run), frame);
}

#[test]
fn a_frame_that_cannot_be_written_ends_the_run_naming_it() {
    let dir = tempfile::tempdir().unwrap();
    let out_dir = dir.path().join("out");
    // A non-empty folder where frame 3 should go: its rename fails.
    std::fs::create_dir_all(out_dir.join("frame_0003.vtu").join("x")).unwrap();
    let out = tetsim(
        dir.path(),
        &["run", "--frames", "12", "--no-pictures", "--out", "out"],
    );
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains("frame_0003.vtu"), "{err}");
    // The frames before it are written and listed; the loop stopped soon after.
    assert!(out_dir.join("frame_0002.vtu").is_file());
    assert!(!out_dir.join("frame_0008.vtu").exists());
    let rows = std::fs::read_to_string(out_dir.join("steps.csv")).unwrap();
    assert_eq!(rows.lines().count(), 4, "header and frames 0..=2");
}
