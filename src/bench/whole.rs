//! The whole run as a user waits for it: the workload run the way `tetsim run --no-pictures`
//! runs it (set-up, frame 0, the first manifest with its frequency estimate, every frame written
//! with its VTU, OBJ and steps.csv row, checkpoints at the default interval, the last manifest),
//! into a scratch folder that is removed afterwards, timed phase by phase beside the step loop.

use std::path::PathBuf;
use std::time::Instant;

use serde::Serialize;

use crate::error::{Error, Result};
use crate::output::Recorder;
use crate::runner::{CheckpointInterval, Runner, fresh_record};
use crate::scene::Scene;
use crate::sim::Simulation;

/// One whole run's figures, s.
#[derive(Clone, Debug, Default, Serialize)]
pub struct WholeRun {
    /// Mesh generation or loading and the simulation's set-up.
    pub setup_seconds: f64,
    /// Frame 0's files and its checkpoint.
    pub first_frame_seconds: f64,
    /// The first manifest.json, with the scene's description and frequency estimate.
    pub manifest_seconds: f64,
    /// The frame loop, until every file is written.
    pub loop_seconds: f64,
    /// The last manifest.json.
    pub finish_seconds: f64,
    /// Everything, per frame.
    pub seconds_per_frame: f64,
    /// The steps alone (steps.csv's wall_seconds), per frame.
    pub step_seconds_per_frame: f64,
    /// seconds_per_frame over step_seconds_per_frame.
    pub ratio: f64,
}

/// Run `scene` whole into a scratch folder (removed afterwards).
pub fn whole_run(scene: &Scene) -> Result<WholeRun> {
    let dir: PathBuf = std::env::temp_dir().join(format!(
        "tetsim-bench-{}-{}",
        std::process::id(),
        scene.solver.frames
    ));
    let result = timed(scene, &dir);
    let _ = std::fs::remove_dir_all(&dir);
    result
}

fn timed(scene: &Scene, dir: &std::path::Path) -> Result<WholeRun> {
    let mut w = WholeRun::default();
    let mut clock = Instant::now();
    let mut lap = || {
        let seconds = clock.elapsed().as_secs_f64();
        clock = Instant::now();
        seconds
    };
    let mut sim = Simulation::from_scene(scene)?;
    w.setup_seconds = lap();
    let mut record = fresh_record(scene, std::path::Path::new("."), dir);
    record.inputs = crate::manifest::input_hashes(scene)?.to_string();
    let mut recorder = Recorder::create(dir, &sim.body, scene.output.obj)?;
    recorder.write_frame(&sim, None)?;
    let mut runner = Runner::new(recorder)
        .with_checkpoint(record)
        .with_interval(CheckpointInterval::of(scene));
    runner.save(&sim)?;
    w.first_frame_seconds = lap();
    runner.recorder.write_manifest(scene, &sim, "running")?;
    w.manifest_seconds = lap();
    let mut steps = 0.0;
    let ending = runner.run(&mut sim, |_, stats| steps += stats.wall_seconds)?;
    w.loop_seconds = lap();
    runner.finish(scene, &sim, &ending)?;
    w.finish_seconds = lap();
    let frames = sim.frame().max(1) as f64;
    if let crate::runner::Ending::Stopped(e) = ending {
        return Err(Error::parameter(
            "bench",
            format!("the whole run stopped: {e}"),
        ));
    }
    let total = w.setup_seconds
        + w.first_frame_seconds
        + w.manifest_seconds
        + w.loop_seconds
        + w.finish_seconds;
    w.seconds_per_frame = total / frames;
    w.step_seconds_per_frame = steps / frames;
    w.ratio = w.seconds_per_frame / w.step_seconds_per_frame.max(1e-12);
    Ok(w)
}
