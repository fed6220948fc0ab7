//! One run's frame loop, the same for the command line and Python: every frame stepped,
//! written and checkpointed, a stop flag honoured between frames (and inside one, through
//! [`Simulation::set_interrupt`]), and the run's ending said one way in manifest.json.

use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

use crate::checkpoint::{Checkpoint, FILE_NAME, RunRecord};
use crate::error::{Error, Result};
use crate::integrator::StepStats;
use crate::output::Recorder;
use crate::scene::Scene;
use crate::sim::Simulation;

/// How a run's frame loop ended.
#[derive(Debug)]
pub enum Ending {
    /// Every frame is done.
    Complete,
    /// The stop flag was set: the files end at the last finished frame.
    Interrupted,
    /// A frame failed under the failure policy: the files end at the frame before it.
    Stopped(Error),
}

impl Ending {
    /// manifest.json's `status`.
    pub fn status(&self) -> String {
        match self {
            Ending::Complete => "complete".into(),
            Ending::Interrupted => "interrupted".into(),
            Ending::Stopped(e) => format!("stopped: {e}"),
        }
    }
}

/// The frame loop with its recorder, checkpoint and stop flag.
pub struct Runner {
    /// Where the frames, steps.csv and manifest.json go.
    pub recorder: Recorder,
    record: Option<RunRecord>,
    stop: Option<Arc<AtomicBool>>,
}

impl Runner {
    /// A loop writing into `recorder`, with no checkpoint and no stop flag.
    pub fn new(recorder: Recorder) -> Self {
        Runner {
            recorder,
            record: None,
            stop: None,
        }
    }

    /// Write `checkpoint.bin` into the recorder's folder after every frame, with `record` as
    /// the run asked for (see [`crate::checkpoint`]).
    pub fn with_checkpoint(mut self, record: RunRecord) -> Self {
        self.record = Some(record);
        self
    }

    /// End the loop before the next frame once `flag` is set (give the simulation the same
    /// flag to stop inside a frame too).
    pub fn with_stop(mut self, flag: Arc<AtomicBool>) -> Self {
        self.stop = Some(flag);
        self
    }

    /// The run as recorded for its checkpoint, when it has one.
    pub fn record(&self) -> Option<&RunRecord> {
        self.record.as_ref()
    }

    /// Write the checkpoint of `sim`'s current state (nothing without one).
    pub fn save(&self, sim: &Simulation) -> Result<()> {
        let Some(record) = &self.record else {
            return Ok(());
        };
        Checkpoint {
            run: record.clone(),
            simulation: sim.snapshot(),
            recorder: self.recorder.snapshot(),
        }
        .write(&self.recorder.dir().join(FILE_NAME))
    }

    /// Run `sim`'s remaining frames (the current state first, when the recorder has written
    /// nothing yet): each is written with its checkpoint, then handed to `each`. Errors other
    /// than a failed frame (a file that could not be written) end the run with that error; the
    /// files written so far stay valid.
    pub fn run(
        &mut self,
        sim: &mut Simulation,
        mut each: impl FnMut(&Simulation, &StepStats),
    ) -> Result<Ending> {
        if self.recorder.frame_files().is_empty() {
            self.recorder.write_frame(sim, None)?;
            self.save(sim)?;
        }
        while !sim.is_finished() {
            if self.stopped() {
                return Ok(Ending::Interrupted);
            }
            let stats = match sim.step() {
                Ok(stats) => stats,
                Err(error @ Error::Solve { .. }) => return Ok(Ending::Stopped(error)),
                Err(Error::Interrupted { .. }) => return Ok(Ending::Interrupted),
                Err(error) => return Err(error),
            };
            self.recorder.write_frame(sim, Some(&stats))?;
            self.save(sim)?;
            each(sim, &stats);
        }
        Ok(Ending::Complete)
    }

    /// Write manifest.json with how the run ended.
    pub fn finish(&mut self, scene: &Scene, sim: &Simulation, ending: &Ending) -> Result<()> {
        self.recorder.write_manifest(scene, sim, &ending.status())
    }

    fn stopped(&self) -> bool {
        self.stop.as_ref().is_some_and(|f| f.load(Ordering::SeqCst))
    }
}

/// The record of a new run of `scene` (its relative paths against `base`) into `out`, for its
/// checkpoint; `inputs` is left for the caller to hash ([`crate::manifest::input_hashes`]) once
/// the scene's files are known to be there.
pub fn fresh_record(scene: &Scene, base: &std::path::Path, out: &std::path::Path) -> RunRecord {
    let base: PathBuf = std::path::absolute(base).unwrap_or(base.to_path_buf());
    RunRecord {
        scene_path: scene.path.display().to_string(),
        scene_base: base.display().to_string(),
        scene_source: scene.source().to_string(),
        inputs: String::new(),
        out: out.display().to_string(),
        frames: scene.solver.frames,
        force: scene.mesh.force,
        pictures: scene.output.pictures,
        plots: scene.output.plots,
        deterministic: scene.output.deterministic,
    }
}
