//! One run's frame loop, the same for the command line and Python: every frame stepped and
//! written, checkpointed at a bounded cost, a stop flag honoured between frames (and inside one,
//! through [`Simulation::set_interrupt`]), and the run's ending said one way in manifest.json.
//!
//! **Output off the critical path.** Each frame is taken from the simulation as owned data
//! ([`FrameTaker`]) and handed to a writer thread that writes its files (VTU, OBJ, PVD,
//! steps.csv, …) and the checkpoints in order while the next frame is computed. The queue holds
//! one job, so at most two frames' data are in flight (one queued, one being written) and memory
//! stays flat. The files are the same bytes, written the same way (temp file + rename), in the
//! same order as without the thread; a failed write ends the run with its error at the next
//! frame, and the loop waits for the writer before it returns.
//!
//! **Checkpoints at a bounded cost** ([`CheckpointInterval`]): written at the first frame, then
//! when `every_seconds` of wall-clock time or `every_frames` frames have passed since the last
//! one, and always when the loop ends (complete, stopped by the flag, or a failed frame): then of
//! the last complete frame. The state of every frame is kept until the next one is done, so that
//! a stop inside a frame can still checkpoint the frame before it.

use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{Receiver, SyncSender, sync_channel};
use std::time::Instant;

use crate::checkpoint::{Checkpoint, FILE_NAME, RunRecord, SimulationState};
use crate::error::{Error, Result};
use crate::integrator::StepStats;
use crate::output::{FrameData, FrameTaker, Recorder};
use crate::scene::Scene;
use crate::sim::Simulation;

/// When a run writes `checkpoint.bin` besides its first frame and its end (`[output]
/// checkpoint_every` and `checkpoint_frames`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CheckpointInterval {
    /// Wall-clock seconds after the last checkpoint at which the next frame writes one; 0: every
    /// frame. Default 30 s.
    pub every_seconds: f64,
    /// Also every this many frames (0: no frame count). Default 0.
    pub every_frames: usize,
}

impl Default for CheckpointInterval {
    fn default() -> Self {
        CheckpointInterval {
            every_seconds: 30.0,
            every_frames: 0,
        }
    }
}

impl CheckpointInterval {
    /// After every frame.
    pub const EVERY_FRAME: CheckpointInterval = CheckpointInterval {
        every_seconds: 0.0,
        every_frames: 1,
    };

    /// The scene's `[output] checkpoint_every` and `checkpoint_frames`.
    pub fn of(scene: &Scene) -> Self {
        CheckpointInterval {
            every_seconds: scene.output.checkpoint_every,
            every_frames: scene.output.checkpoint_frames,
        }
    }

    /// Whether a frame `frames` after the last checkpoint, `seconds` after it, writes one.
    fn due(&self, frames: usize, seconds: f64) -> bool {
        seconds >= self.every_seconds || (self.every_frames > 0 && frames >= self.every_frames)
    }
}

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
    interval: CheckpointInterval,
    stop: Option<Arc<AtomicBool>>,
}

/// What the writer thread is handed.
enum Job {
    /// A frame's files.
    Frame(Box<FrameData>),
    /// The checkpoint of the frame written last.
    Checkpoint(Box<SimulationState>),
}

impl Runner {
    /// A loop writing into `recorder`, with no checkpoint and no stop flag.
    pub fn new(recorder: Recorder) -> Self {
        Runner {
            recorder,
            record: None,
            interval: CheckpointInterval::default(),
            stop: None,
        }
    }

    /// Write `checkpoint.bin` into the recorder's folder (see [`crate::checkpoint`]), with
    /// `record` as the run asked for, at the interval of [`Runner::with_interval`].
    pub fn with_checkpoint(mut self, record: RunRecord) -> Self {
        self.record = Some(record);
        self
    }

    /// Checkpoint at `interval` (default: [`CheckpointInterval::default`]).
    pub fn with_interval(mut self, interval: CheckpointInterval) -> Self {
        self.interval = interval;
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

    /// Write the checkpoint of `sim`'s current state now (nothing without one).
    pub fn save(&self, sim: &Simulation) -> Result<()> {
        match &self.record {
            Some(record) => write_checkpoint(&self.recorder, record, sim.snapshot()),
            None => Ok(()),
        }
    }

    /// Run `sim`'s remaining frames (the current state first, when the recorder has written
    /// nothing yet): each is handed to the writer thread, checkpointed when due, then handed to
    /// `each`. Returns once every file is written. Errors other than a failed frame (a file that
    /// could not be written) end the run with that error; the files written so far stay valid.
    pub fn run(
        &mut self,
        sim: &mut Simulation,
        each: impl FnMut(&Simulation, &StepStats),
    ) -> Result<Ending> {
        if self.recorder.frame_files().is_empty() {
            self.recorder.write_frame(sim, None)?;
            self.save(sim)?;
        }
        if !self.recorder.is_started() {
            return Err(Error::parameter(
                "output",
                "the recorder was neither given a first frame nor resumed",
            ));
        }
        let taker = FrameTaker::new(sim);
        let Runner {
            recorder,
            record,
            interval,
            stop,
        } = self;
        let record = record.as_ref();
        std::thread::scope(|scope| {
            let (jobs, queue) = sync_channel::<Job>(1);
            let writer = std::thread::Builder::new()
                .name("tetsim-writer".into())
                .spawn_scoped(scope, move || write_jobs(recorder, record, queue))
                .map_err(|e| Error::parameter("output", format!("no writer thread: {e}")))?;
            let loop_ended = frames(sim, &taker, &jobs, record.is_some(), interval, stop, each);
            drop(jobs);
            let written = match writer.join() {
                Ok(written) => written,
                Err(panic) => std::panic::resume_unwind(panic),
            };
            // A file that could not be written is the run's error, whatever the loop met.
            written?;
            loop_ended
        })
    }

    /// Write the render surfaces' animation (`render.glb`, over every frame written, those
    /// before a resume included) and manifest.json with how the run ended.
    pub fn finish(&mut self, scene: &Scene, sim: &Simulation, ending: &Ending) -> Result<()> {
        self.recorder.write_animation()?;
        self.recorder.write_manifest(scene, sim, &ending.status())
    }
}

/// The frame loop proper: step, hand the frame (and its checkpoint when due) to the writer, and
/// at the end the checkpoint of the last complete frame. Returns early, without an error of its
/// own, when the writer has stopped (its error is the run's).
fn frames(
    sim: &mut Simulation,
    taker: &FrameTaker,
    jobs: &SyncSender<Job>,
    checkpoints: bool,
    interval: &CheckpointInterval,
    stop: &Option<Arc<AtomicBool>>,
    mut each: impl FnMut(&Simulation, &StepStats),
) -> Result<Ending> {
    let stopped = || stop.as_ref().is_some_and(|f| f.load(Ordering::SeqCst));
    // The last frame's state while it has no checkpoint, and when and which the last one was.
    let mut unsaved: Option<SimulationState> = None;
    let mut saved_at = (sim.frame(), Instant::now());
    let ending = loop {
        if sim.is_finished() {
            break Ending::Complete;
        }
        if stopped() {
            break Ending::Interrupted;
        }
        let stats = match sim.step() {
            Ok(stats) => stats,
            Err(error @ Error::Solve { .. }) => break Ending::Stopped(error),
            Err(Error::Interrupted { .. }) => break Ending::Interrupted,
            Err(error) => return Err(error),
        };
        // The frame before this one is no longer the last complete frame: its state goes
        // before this frame's is copied, so that at most one copy is held.
        unsaved = None;
        if jobs
            .send(Job::Frame(Box::new(taker.take(sim, Some(&stats)))))
            .is_err()
        {
            return Ok(Ending::Interrupted);
        }
        if checkpoints {
            let state = sim.snapshot();
            let (frame, since) = saved_at;
            if interval.due(sim.frame() - frame, since.elapsed().as_secs_f64()) {
                saved_at = (sim.frame(), Instant::now());
                if jobs.send(Job::Checkpoint(Box::new(state))).is_err() {
                    return Ok(Ending::Interrupted);
                }
            } else {
                unsaved = Some(state);
            }
        }
        each(sim, &stats);
    };
    if let Some(state) = unsaved {
        // The writer's error, if it stopped, is reported by the caller.
        let _ = jobs.send(Job::Checkpoint(Box::new(state)));
    }
    Ok(ending)
}

/// The writer thread: each job in order, until the queue closes or a write fails.
fn write_jobs(
    recorder: &mut Recorder,
    record: Option<&RunRecord>,
    queue: Receiver<Job>,
) -> Result<()> {
    for job in queue {
        match job {
            Job::Frame(data) => recorder.write(*data)?,
            Job::Checkpoint(state) => {
                if let Some(record) = record {
                    write_checkpoint(recorder, record, *state)?;
                }
            }
        }
    }
    Ok(())
}

/// `checkpoint.bin` of `simulation` with the recorder's bookkeeping as it is now (the frame
/// written last must be the simulation's).
fn write_checkpoint(
    recorder: &Recorder,
    record: &RunRecord,
    simulation: SimulationState,
) -> Result<()> {
    Checkpoint {
        run: record.clone(),
        simulation,
        recorder: recorder.snapshot(),
    }
    .write(&recorder.dir().join(FILE_NAME))
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
