//! `tetsim.Simulation`: step a scene frame by frame, read and set its state, move its fixed
//! vertices, or run the rest of it into the files `tetsim run` writes.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::Duration;

use pyo3::prelude::*;
use pyo3::types::{PyDict, PyTuple};
use tetsim::boundary::Motion;
use tetsim::integrator::StepStats;
use tetsim::math::Vec3;
use tetsim::output::{Cell, Recorder, step_columns};
use tetsim::runner::{CheckpointInterval, Ending, Runner};

use tetsim::scene::units::Kind;

use crate::args::{self, Signature};
use crate::arrays;
use crate::errors::{LibResult, argument, for_path, from_lib};
use crate::scene::Scene;

/// A running simulation of a scene: its body, boundary conditions, state and solver.
///
/// Vertex arrays (positions, velocities, rest_positions, tets, fixed vertices) use the mesh
/// file's numbering, the same as the output frames. Between steps you may set positions and
/// velocities and move the fixed vertices (set_fixed_motion, set_fixed_targets); each value is
/// checked like the same value in a scene file. The GIL is released while stepping.
#[pyclass(module = "tetsim")]
pub struct Simulation {
    /// Behind a mutex only because Python objects must be shareable between threads (and the
    /// solver's boxed strategies are not `Sync`); `&mut self` methods reach it without locking.
    sim: Mutex<tetsim::Simulation>,
    scene: tetsim::Scene,
    origin: crate::errors::Origin,
    /// Set on Ctrl-C while a step runs (see [`interruptible`]); the step then stops.
    interrupt: Arc<AtomicBool>,
}

#[pymethods]
impl Simulation {
    /// Build everything the scene describes (reads its mesh), ready to step from frame 0.
    #[new]
    #[pyo3(signature = (scene=None, *extra, **unknown), text_signature = "(scene)")]
    fn new(
        py: Python<'_>,
        scene: Option<&Bound<'_, PyAny>>,
        extra: &Bound<'_, PyTuple>,
        unknown: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Self> {
        signature("Simulation", &["scene"]).check(extra, unknown)?;
        let what = "a tetsim.Scene (Scene.load(path), Scene.from_dict(values) or Scene.default())";
        let scene = args::required(scene, "scene", "Simulation", what)?;
        let scene = scene.cast::<Scene>().map_err(|_| {
            argument(
                "scene",
                format!("expected {what}, got {}", args::describe(scene)),
            )
        })?;
        let scene = scene.get();
        let inner = &scene.inner;
        let sim = py
            .detach(|| tetsim::Simulation::from_scene(inner))
            .map_err(|e| from_lib(e, scene.origin))?;
        let interrupt = Arc::new(AtomicBool::new(false));
        let mut sim = sim;
        sim.set_interrupt(Arc::clone(&interrupt));
        Ok(Simulation {
            sim: Mutex::new(sim),
            scene: scene.inner.clone(),
            origin: scene.origin,
            interrupt,
        })
    }

    /// Advance one frame (all its substeps) and return its row of steps.csv as a dict: frame,
    /// time, newton_iterations, cg_iterations, residual, converged, elastic_energy,
    /// kinetic_energy, min_J, inverted_elements, wall_seconds, … (tetsim.STEPS_COLUMNS, then
    /// tetsim.CONTACT_COLUMNS when contact is on; min_distance is None when nothing is near).
    ///
    /// Raises tetsim.Error when the run is finished, or when the frame fails under the scene's
    /// [solver] on_failure (the state is then left as it was before the step). Ctrl-C stops the
    /// frame within a Newton iteration and raises KeyboardInterrupt, the state left as it was.
    #[pyo3(signature = (*extra, **unknown), text_signature = "($self)")]
    fn step<'py>(
        &mut self,
        py: Python<'py>,
        extra: &Bound<'py, PyTuple>,
        unknown: Option<&Bound<'py, PyDict>>,
    ) -> PyResult<Bound<'py, PyDict>> {
        signature("Simulation.step", &[]).check(extra, unknown)?;
        let origin = self.origin;
        let flag = Arc::clone(&self.interrupt);
        let sim = self.sim_mut();
        check_not_finished(sim)?;
        let (done, signal) = interruptible(py, &flag, || sim.step());
        if let Some(e) = signal {
            return Err(e);
        }
        let stats = done.map_err(|e| from_lib(e, origin))?;
        columns(py, &stats, sim.contact_setup().is_some())
    }

    /// Run every remaining frame, writing what `tetsim run --no-pictures` writes into out_dir
    /// (default: the scene's [output] dir): frame_NNNN.vtu (the current frame first), frames.pvd,
    /// surface_NNNN.obj, steps.csv, timings.csv and manifest.json, with the same bytes.
    /// deterministic=True writes steps.csv's wall_seconds as 0 (like --deterministic; default:
    /// the scene's [output] deterministic). Pictures are left out: plot with matplotlib, or
    /// draw them with `tetsim render OUT_DIR`.
    ///
    /// Returns the steps dicts of the frames run. Ctrl-C stops the frame being computed within a
    /// Newton iteration (raising KeyboardInterrupt): the files end at the last complete frame,
    /// every one valid, and the manifest says so.
    #[pyo3(
        signature = (out_dir=None, deterministic=None, *extra, **unknown),
        text_signature = "($self, out_dir=None, deterministic=None)"
    )]
    fn run<'py>(
        &mut self,
        py: Python<'py>,
        out_dir: Option<&Bound<'py, PyAny>>,
        deterministic: Option<&Bound<'py, PyAny>>,
        extra: &Bound<'py, PyTuple>,
        unknown: Option<&Bound<'py, PyDict>>,
    ) -> PyResult<Vec<Bound<'py, PyDict>>> {
        signature("Simulation.run", &["out_dir", "deterministic"]).check(extra, unknown)?;
        let out_dir = args::optional_path(out_dir, "out_dir")?;
        let deterministic = args::optional_flag(deterministic, "deterministic")?;
        let mut scene = self.scene.clone();
        scene.output.deterministic = deterministic.unwrap_or(scene.output.deterministic);
        // What this run writes, as the manifest records it: no pictures, no plots.
        scene.output.pictures = false;
        scene.output.plots = false;
        let out = out_dir.unwrap_or_else(|| scene.output.dir.clone());
        let origin = self.origin;
        let flag = Arc::clone(&self.interrupt);
        let sim = self.sim_mut();
        let mut recorder = Recorder::create(&out, &sim.body, scene.output.obj)
            .map_err(|e| for_path(e, origin, "out_dir", &out))?
            .deterministic(scene.output.deterministic);
        recorder.write_frame(&*sim, None).py()?;
        // The same loop as the command line's: checkpoints as the scene says, so that
        // `tetsim run --resume OUT` goes on with the run.
        let mut record = tetsim::runner::fresh_record(&scene, &scene.base_dir, &out);
        record.inputs = tetsim::manifest::input_hashes(&scene).py()?.to_string();
        let mut runner = Runner::new(recorder)
            .with_checkpoint(record)
            .with_interval(CheckpointInterval::of(&scene))
            .with_stop(Arc::clone(&flag));
        runner.save(&*sim).py()?;
        let mut all = Vec::new();
        let (ending, signal) = interruptible(py, &flag, || {
            runner.run(&mut *sim, |_, stats| all.push(stats.clone()))
        });
        let ending = ending.py()?;
        runner.finish(&scene, &*sim, &ending).py()?;
        let contact = sim.contact_setup().is_some();
        let rows = all
            .iter()
            .map(|stats| columns(py, stats, contact))
            .collect::<PyResult<Vec<_>>>()?;
        let interrupted = match (&ending, signal) {
            (_, Some(e)) => Some(e),
            (Ending::Interrupted, None) => py.check_signals().err(),
            _ => None,
        };
        let failure = match ending {
            Ending::Stopped(error) => Some(error),
            _ => None,
        };
        if let Some(e) = interrupted {
            return Err(e);
        }
        if let Some(e) = failure {
            return Err(from_lib(e, origin));
        }
        Ok(rows)
    }

    /// Current positions, m: (n, 3) float64, a copy. Setting it moves every vertex (checked
    /// like [initial] positions: n finite rows, each coordinate within 1e9 m; none inside an
    /// obstacle). Constrained components are set again by their constraint at the next step. A
    /// refused value changes nothing.
    #[getter]
    fn positions<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let sim = self.lock();
        arrays::from_vec3s(py, &sim.to_input_order(&sim.state.x))
    }

    #[setter]
    fn set_positions(&mut self, value: &Bound<'_, PyAny>) -> PyResult<()> {
        let sim = self.sim_mut();
        let n = sim.body.vertex_count();
        let x = arrays::vec3s(value, "positions", Some(n))?;
        sim.set_positions(&x).py()
    }

    /// Current velocities, m/s: (n, 3) float64, a copy. Setting it checks n finite rows, each
    /// component within 1e8 m/s; constrained components are set to zero (their constraint moves
    /// them), and a quasistatic run accepts only zeros. A refused value changes nothing.
    #[getter]
    fn velocities<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let sim = self.lock();
        arrays::from_vec3s(py, &sim.to_input_order(&sim.state.v))
    }

    #[setter]
    fn set_velocities(&mut self, value: &Bound<'_, PyAny>) -> PyResult<()> {
        let sim = self.sim_mut();
        let n = sim.body.vertex_count();
        let v = arrays::vec3s(value, "velocities", Some(n))?;
        sim.set_velocities(&v).py()
    }

    /// Rest positions of the mesh, m: (n, 3) float64.
    #[getter]
    fn rest_positions<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let sim = self.lock();
        arrays::from_vec3s(py, &sim.to_input_order(&sim.body.mesh.positions))
    }

    /// The tets: (m, 4) int64 vertex indices into positions; (m, 10) for quadratic tets
    /// (corners, then the nodes on edges 01, 12, 02, 03, 13, 23).
    #[getter]
    fn tets<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let sim = self.lock();
        match sim.input_quadratic_tets() {
            Some(tets) => arrays::from_tets(py, &tets),
            None => arrays::from_tets(py, &sim.input_tets()),
        }
    }

    /// Time, s (quasistatic: the load factor, 0 to 1).
    #[getter]
    fn time(&self) -> f64 {
        let sim = self.lock();
        sim.state.t
    }

    /// Frames done so far (0 before the first step).
    #[getter]
    fn frame(&self) -> usize {
        let sim = self.lock();
        sim.frame()
    }

    /// Frames of the whole run ([solver] frames).
    #[getter]
    fn frames(&self) -> usize {
        let sim = self.lock();
        sim.params.frames
    }

    /// True once every frame of the run is done.
    #[getter]
    fn is_finished(&self) -> bool {
        let sim = self.lock();
        sim.is_finished()
    }

    /// The scene this simulation was built from.
    #[getter]
    fn scene(&self) -> Scene {
        Scene {
            inner: self.scene.clone(),
            origin: self.origin,
        }
    }

    /// How many [[fixed]] entries the scene has (index them from 0).
    #[getter]
    fn fixed_count(&self) -> usize {
        let sim = self.lock();
        sim.boundary.constraints.len()
    }

    /// The vertices of [[fixed]] entry `index` (0-based: [[fixed]] #1 is 0), sorted: (k,) int64.
    /// set_fixed_targets takes one target per vertex, in this order.
    #[pyo3(signature = (index=None, *extra, **unknown), text_signature = "($self, index)")]
    fn fixed_vertices<'py>(
        &self,
        py: Python<'py>,
        index: Option<&Bound<'py, PyAny>>,
        extra: &Bound<'py, PyTuple>,
        unknown: Option<&Bound<'py, PyDict>>,
    ) -> PyResult<Bound<'py, PyAny>> {
        signature("Simulation.fixed_vertices", &["index"]).check(extra, unknown)?;
        let sim = self.lock();
        let index = fixed_index(&sim, index, "Simulation.fixed_vertices")?;
        arrays::from_indices(py, &sim.fixed_vertices(index).py()?)
    }

    /// Give [[fixed]] entry `index` a new motion of its frame-0 positions, the keys of the
    /// scene's `motion` and `duration` with their checks: rotate by rotate_degrees about axis
    /// through center, then translate; ramped linearly over duration seconds from the start of
    /// the run (None: the whole run; 0: at once). Takes effect at the next step and replaces
    /// targets set by set_fixed_targets. Values are numbers in the key's unit or strings with a
    /// unit ("5 mm", "0.5 rad", "200 ms"); None is the default. A refused value (not finite,
    /// beyond its unit's cap, a rotation about a zero axis) changes nothing.
    #[pyo3(
        signature = (index=None, translate=None, rotate_degrees=None, axis=None, center=None, duration=None, *extra, **unknown),
        text_signature = "($self, index, translate=(0, 0, 0), rotate_degrees=0, axis=(1, 0, 0), center=(0, 0, 0), duration=None)"
    )]
    #[allow(clippy::too_many_arguments)]
    fn set_fixed_motion(
        &mut self,
        index: Option<&Bound<'_, PyAny>>,
        translate: Option<&Bound<'_, PyAny>>,
        rotate_degrees: Option<&Bound<'_, PyAny>>,
        axis: Option<&Bound<'_, PyAny>>,
        center: Option<&Bound<'_, PyAny>>,
        duration: Option<&Bound<'_, PyAny>>,
        extra: &Bound<'_, PyTuple>,
        unknown: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<()> {
        signature(
            "Simulation.set_fixed_motion",
            &[
                "index",
                "translate",
                "rotate_degrees",
                "axis",
                "center",
                "duration",
            ],
        )
        .check(extra, unknown)?;
        let sim = self.sim_mut();
        let index = fixed_index(sim, index, "Simulation.set_fixed_motion")?;
        let vector =
            |value: Option<&Bound<'_, PyAny>>, key: &str, kind: Kind, default: Vec3| match value {
                Some(v) if !v.is_none() => args::vec3(v, key, kind).map(Vec3::from),
                _ => Ok(default),
            };
        let motion = Motion {
            translate: vector(translate, "translate", Kind::Length, Vec3::zeros())?,
            rotate_degrees: args::optional_real(rotate_degrees, "rotate_degrees", Kind::Degrees)?
                .unwrap_or(0.0),
            axis: vector(axis, "axis", Kind::Ratio, Vec3::x())?,
            center: vector(center, "center", Kind::Length, Vec3::zeros())?,
        };
        let duration = args::optional_real(duration, "duration", Kind::Time)?;
        sim.set_fixed_motion(index, motion, duration).py()
    }

    /// Hold the vertices of [[fixed]] entry `index` at `targets` ((k, 3) float64, one finite row
    /// per vertex of fixed_vertices(index), in its order, within 1e9 m) from the next step on, in
    /// place of the entry's motion. Only its constrained components follow.
    #[pyo3(
        signature = (index=None, targets=None, *extra, **unknown),
        text_signature = "($self, index, targets)"
    )]
    fn set_fixed_targets(
        &mut self,
        index: Option<&Bound<'_, PyAny>>,
        targets: Option<&Bound<'_, PyAny>>,
        extra: &Bound<'_, PyTuple>,
        unknown: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<()> {
        let call = "Simulation.set_fixed_targets";
        signature(call, &["index", "targets"]).check(extra, unknown)?;
        let sim = self.sim_mut();
        let index = fixed_index(sim, index, call)?;
        let k = sim.fixed_vertices(index).py()?.len();
        let targets = args::required(targets, "targets", call, "a (k, 3) float64 array")?;
        let targets = arrays::vec3s(targets, "targets", Some(k))?;
        sim.set_fixed_targets(index, &targets).py()
    }

    fn __repr__(&self) -> String {
        let sim = self.lock();
        format!(
            "Simulation(vertices={}, tets={}, frame={}/{}, time={})",
            sim.body.vertex_count(),
            sim.body.mesh.tets.len(),
            sim.frame(),
            sim.params.frames,
            sim.state.t
        )
    }
}

impl Simulation {
    /// The simulation, for `&self` methods.
    fn lock(&self) -> MutexGuard<'_, tetsim::Simulation> {
        self.sim.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// The simulation, for `&mut self` methods (no locking).
    fn sim_mut(&mut self) -> &mut tetsim::Simulation {
        self.sim.get_mut().unwrap_or_else(|e| e.into_inner())
    }
}

/// Runs `work` (a step) on a helper thread while this one, waking every 50 ms to take the
/// GIL, lets Python see its signals: a Ctrl-C sets `flag`, which ends the step within one Newton
/// iteration, and is returned beside the work's result (for the caller to raise). A step that
/// ends sooner is waited for no longer than it takes.
fn interruptible<T: Send>(
    py: Python<'_>,
    flag: &AtomicBool,
    work: impl FnOnce() -> T + Send,
) -> (T, Option<PyErr>) {
    use std::sync::Condvar;
    flag.store(false, Ordering::SeqCst);
    let finished = (Mutex::new(false), Condvar::new());
    std::thread::scope(|scope| {
        let handle = scope.spawn(|| {
            let result = work();
            *finished.0.lock().unwrap_or_else(|e| e.into_inner()) = true;
            finished.1.notify_all();
            result
        });
        let mut signal = None;
        loop {
            let done = py.detach(|| {
                let guard = finished.0.lock().unwrap_or_else(|e| e.into_inner());
                let (guard, _) = finished
                    .1
                    .wait_timeout_while(guard, Duration::from_millis(50), |done| !*done)
                    .unwrap_or_else(|e| e.into_inner());
                *guard
            });
            // A panicking step never says it finished.
            if done || handle.is_finished() {
                break;
            }
            if signal.is_none()
                && let Err(e) = py.check_signals()
            {
                flag.store(true, Ordering::SeqCst);
                signal = Some(e);
            }
        }
        let done = handle
            .join()
            .unwrap_or_else(|panic| std::panic::resume_unwind(panic));
        (done, signal)
    })
}

/// A method's parameters, all positional or keyword (for [`Signature::check`]).
fn signature<'a>(call: &'a str, positional: &'a [&'a str]) -> Signature<'a> {
    Signature {
        call,
        positional,
        keyword: &[],
    }
}

/// The `index` argument of a method about a [[fixed]] entry.
fn fixed_index(
    sim: &tetsim::Simulation,
    index: Option<&Bound<'_, PyAny>>,
    call: &str,
) -> PyResult<usize> {
    let what = "the [[fixed]] entry, numbered from 0";
    let index = args::required(index, "index", call, what)?;
    args::index(
        index,
        "index",
        sim.boundary.constraints.len(),
        "[[fixed]] entry",
    )
}

/// One frame's steps.csv columns as a dict.
fn columns<'py>(py: Python<'py>, stats: &StepStats, contact: bool) -> PyResult<Bound<'py, PyDict>> {
    let dict = PyDict::new(py);
    for (name, cell) in step_columns(stats, contact) {
        match cell {
            Cell::Count(n) => dict.set_item(name, n)?,
            Cell::Real(x) => dict.set_item(name, x)?,
            Cell::Flag(b) => dict.set_item(name, b)?,
            Cell::Empty => dict.set_item(name, py.None())?,
        }
    }
    Ok(dict)
}

/// Stepping past the last frame is refused: ramps and load factors end there.
fn check_not_finished(sim: &tetsim::Simulation) -> PyResult<()> {
    if sim.is_finished() {
        return Err(argument(
            "solver.frames",
            format!(
                "the run is finished: all {} frames are done (is_finished is True)",
                sim.params.frames
            ),
        ));
    }
    Ok(())
}
