//! The library's front door: a [`Simulation`] owns the body, its boundary conditions, the state
//! and the solver, and advances frame by frame, cutting the step when a frame fails (per
//! [`OnFailure`]).
//!
//! ```
//! use tetsim::{Scene, Simulation};
//! let mut scene = Scene::default();
//! scene.solver.frames = 2;
//! let mut sim = Simulation::from_scene(&scene).unwrap();
//! while !sim.is_finished() {
//!     let stats = sim.step().unwrap();
//!     assert!(stats.converged);
//! }
//! ```

mod acceleration;
mod added;
mod checkpoint;
mod contact;
mod control;
mod energy;
mod monitoring;
mod recovery;
mod render;
mod validity;

pub use render::RenderBody;

use std::time::Instant;

use crate::audit::Ledger;
use crate::boundary::{Boundary, Clock};
use crate::elastic::ElasticBody;
use crate::error::{Error, Result};
use crate::integrator::scheme::History;
use crate::integrator::{
    Integrator, Newton, OnFailure, SolverParams, StepContext, StepKind, StepStart, StepStats,
};
use crate::math::Vec3;
use crate::mesh::ordering::Renumbering;

/// Positions (m), velocities (m/s) and time (s; the load factor when quasistatic).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct State {
    /// Current positions.
    pub x: Vec<Vec3>,
    /// Current velocities.
    pub v: Vec<Vec3>,
    /// Current time.
    pub t: f64,
}

/// A body, its boundary, its state and the solver: advance it with [`Simulation::step`].
pub struct Simulation {
    /// The elastic body.
    pub body: ElasticBody,
    /// Constraints, loads, gravity.
    pub boundary: Boundary,
    /// Solver settings.
    pub params: SolverParams,
    /// The current state.
    pub state: State,
    initial: Vec<Vec3>,
    frame: usize,
    free: Vec<Vec3>,
    f_ext: Vec<Vec3>,
    xn: Vec<Vec3>,
    vn: Vec<Vec3>,
    /// What the time scheme keeps between steps, and at the start of the frame.
    history: History,
    saved_history: History,
    saved: State,
    newton: Newton,
    ledger: Ledger,
    saved_ledger: Ledger,
    /// The positions the ledger was made for: `state` is public, and a caller that moves it
    /// between frames must not show up as energy created by the step.
    ledger_x: Vec<Vec3>,
    renumbering: Option<Renumbering>,
    /// Which vertices and tets (input order) belong to which body.
    bodies: crate::mesh::bodies::Bodies,
    /// Frames the motions and loads ramp over when not `params.frames` (a resumed run taken
    /// further than it was started for keeps its ramps).
    ramp_frames: Option<usize>,
    /// The Rayleigh coefficients' origin when a damping ratio set them.
    damping: Option<crate::modes::DampingResolution>,
    /// Probes and named constraints recorded every frame (SPEC §13).
    monitors: crate::monitor::Monitors,
    /// Under MPI on rank 0: what steps the ranks' parts and gathers their state into this whole
    /// simulation's, which then only reads and writes (see [`crate::parallel`]).
    driver: Option<Box<dyn crate::parallel::Driver>>,
    /// Inverted tets at the end of the last frame (over every rank; `usize::MAX`: not known).
    inverted_at_end: usize,
    /// Tangled elements (over every rank).
    tangled_total: usize,
    /// Whether the last attempt at a frame ended with a moving obstacle that could not get
    /// through the body.
    blocked: bool,
    /// Detailed surfaces embedded in the bodies (output only).
    render: Vec<render::RenderBody>,
}

impl Simulation {
    /// A simulation starting from `initial` (positions and velocities of every vertex). The
    /// initial positions are also the reference that prescribed motions move.
    pub fn new(
        body: ElasticBody,
        boundary: Boundary,
        params: SolverParams,
        initial: State,
    ) -> Result<Self> {
        check_params(&params)?;
        let n = body.vertex_count();
        if initial.x.len() != n || initial.v.len() != n {
            return Err(Error::parameter(
                "initial",
                format!(
                    "the initial state has {} positions and {} velocities for {n} vertices",
                    initial.x.len(),
                    initial.v.len()
                ),
            ));
        }
        if !initial
            .x
            .iter()
            .chain(&initial.v)
            .all(|p| p.iter().all(|c| c.is_finite()))
        {
            return Err(Error::parameter(
                "initial",
                "the initial state has a non-finite position or velocity",
            ));
        }
        let free = boundary.free_mask(n);
        let newton = Newton::new(&body, &params);
        let bodies = crate::mesh::bodies::Bodies::single("body0", &body.mesh);
        let mut state = initial;
        // Constrained components start where their motion starts (ramp 0 is the identity, but a
        // component fixed in place must not drift with an initial velocity).
        for (v, m) in state.v.iter_mut().zip(&free) {
            *v = v.component_mul(m);
        }
        if params.integrator == Integrator::Quasistatic {
            state.v.iter_mut().for_each(|v| *v = Vec3::zeros());
        }
        let ledger = initial_ledger(&body, &boundary, &free, &state.x, None);
        Ok(Simulation {
            ledger_x: state.x.clone(),
            saved_ledger: ledger.clone(),
            ledger,
            initial: state.x.clone(),
            frame: 0,
            f_ext: vec![Vec3::zeros(); n],
            xn: vec![Vec3::zeros(); n],
            vn: vec![Vec3::zeros(); n],
            history: History::default(),
            saved_history: History::default(),
            saved: state.clone(),
            free,
            newton,
            body,
            boundary,
            params,
            state,
            renumbering: None,
            bodies,
            ramp_frames: None,
            damping: None,
            monitors: Default::default(),
            driver: None,
            inverted_at_end: usize::MAX,
            tangled_total: 0,
            blocked: false,
            render: Vec::new(),
        })
    }

    /// Newton's workspace (under MPI, to hand its terms and solver to the ranks: see
    /// [`crate::parallel`]).
    #[cfg(feature = "mpi")]
    pub fn newton_mut(&mut self) -> &mut Newton {
        &mut self.newton
    }

    /// Make this simulation one rank's part of a distributed one: every sum it and its Newton
    /// decide on is then a sum over the ranks (see [`crate::parallel`]).
    pub fn set_ranks(&mut self, ranks: std::sync::Arc<dyn crate::parallel::Ranks>) {
        self.ledger = initial_ledger(
            &self.body,
            &self.boundary,
            &self.free,
            &self.state.x,
            Some(&*ranks),
        );
        self.saved_ledger.clone_from(&self.ledger);
        self.newton.set_ranks(ranks);
    }

    /// Hand the stepping to `driver` (rank 0 under MPI): [`Simulation::step`] then advances the
    /// ranks' parts and this simulation's state is the gathered whole.
    /// This simulation's own Newton is dropped for an empty one (its workspace is O(tets)).
    pub fn set_driver(&mut self, driver: Box<dyn crate::parallel::Driver>) {
        self.driver = Some(driver);
        self.newton = Newton::new(&self.body.part(&[], &[]), &self.params);
    }

    /// Say that the body's mesh is a renumbering of the input mesh (see
    /// [`crate::mesh::ordering`]), so that output is written in the input's numbering.
    pub fn with_renumbering(mut self, renumbering: Option<Renumbering>) -> Self {
        self.renumbering = renumbering;
        self
    }

    /// Name the bodies merged into this simulation's mesh (SPEC §11 `[[body]]`): outputs tag
    /// every vertex and tet with its body.
    pub fn with_bodies(mut self, bodies: crate::mesh::bodies::Bodies) -> Self {
        self.bodies = bodies;
        self
    }

    /// Record that `params`' Rayleigh coefficients come from a damping ratio (SPEC §13), for
    /// the run's report and manifest.
    pub fn with_damping(mut self, damping: Option<crate::modes::DampingResolution>) -> Self {
        self.damping = damping;
        self
    }

    /// The damping ratio the Rayleigh coefficients were resolved from, if any.
    pub fn damping(&self) -> Option<&crate::modes::DampingResolution> {
        self.damping.as_ref()
    }

    /// Record probes and the reactions of named constraints every frame (SPEC §13; the
    /// recorder writes probes.csv and reactions.csv from them).
    pub fn with_monitors(mut self, monitors: crate::monitor::Monitors) -> Self {
        self.newton
            .potential_mut()
            .record_constrained_forces(!monitors.reactions.is_empty());
        self.monitors = monitors;
        self
    }

    /// The probes and named constraints this simulation records.
    pub fn monitors(&self) -> &crate::monitor::Monitors {
        &self.monitors
    }

    /// The bodies in the mesh, in input order (one, "body0", unless named).
    pub fn bodies(&self) -> &crate::mesh::bodies::Bodies {
        &self.bodies
    }

    /// The ramp factor s ∈ [0, 1] of a motion with `duration` (None: the whole run) at the
    /// current time (quasistatic: the load factor).
    pub fn motion_ramp(&self, duration: Option<f64>) -> f64 {
        self.clock_at(self.state.t).ramp(duration)
    }

    /// Frames the motions and loads ramp over: the run's frames unless a resumed run was taken
    /// further ([`Simulation::restore`]).
    pub fn ramp_frames(&self) -> usize {
        self.ramp_frames.unwrap_or(self.params.frames)
    }

    /// The boundary clock at time (or load factor) t.
    fn clock_at(&self, t: f64) -> Clock {
        if self.params.integrator.is_dynamic() {
            Clock::Time {
                time: t,
                run_duration: self.params.dt * self.ramp_frames() as f64,
            }
        } else {
            Clock::LoadFactor(t)
        }
    }

    /// How the body's mesh renumbers the input mesh (None: it is the input's numbering).
    pub fn renumbering(&self) -> Option<&Renumbering> {
        self.renumbering.as_ref()
    }

    /// The body at rest: positions = rest positions, zero velocity.
    pub fn rest_state(body: &ElasticBody) -> State {
        State {
            x: body.mesh.positions.clone(),
            v: vec![Vec3::zeros(); body.vertex_count()],
            t: 0.0,
        }
    }

    /// Frames done so far (0 before the first step).
    pub fn frame(&self) -> usize {
        self.frame
    }

    /// A flag that, once set (by a signal handler, a watchdog, another thread), stops the frame
    /// being computed within one Newton iteration: [`Simulation::step`] then returns
    /// [`Error::Interrupted`] with the state of the last complete frame. Serial runs only (see
    /// [`crate::integrator::Newton::interrupted`]).
    pub fn set_interrupt(&mut self, flag: std::sync::Arc<std::sync::atomic::AtomicBool>) {
        self.newton.set_interrupt(Some(flag));
    }

    /// True once every frame of `params.frames` is done.
    pub fn is_finished(&self) -> bool {
        self.frame >= self.params.frames
    }

    /// The positions at frame 0.
    pub fn initial_positions(&self) -> &[Vec3] {
        &self.initial
    }

    /// 0/1 mask of free DOFs per vertex.
    pub fn free_mask(&self) -> &[Vec3] {
        &self.free
    }

    /// Bytes the CG operator and preconditioner move per CG iteration (a model; see
    /// `tetsim bench`). On the assembled path it is known after the first frame.
    pub fn operator_bytes_per_product(&self) -> f64 {
        self.newton.bytes_per_cg_iteration(&self.body)
    }

    /// Where the memory goes: the mesh, the state, Newton's and the linear solver's large
    /// buffers (contact's are not counted), bytes per part.
    pub fn memory_inventory(&self) -> crate::memory::Inventory {
        use crate::memory::vec_bytes;
        let mut inventory = crate::memory::Inventory::default();
        self.body.add_memory(&mut inventory);
        inventory.add(
            "state and frame vectors (x, v, x₀, mask, loads, saved)",
            vec_bytes(&self.state.x)
                + vec_bytes(&self.state.v)
                + vec_bytes(&self.initial)
                + vec_bytes(&self.free)
                + vec_bytes(&self.f_ext)
                + vec_bytes(&self.xn)
                + vec_bytes(&self.vn)
                + vec_bytes(&self.saved.x)
                + vec_bytes(&self.saved.v)
                + vec_bytes(&self.ledger_x),
        );
        self.newton.add_memory(&mut inventory);
        inventory
    }

    /// The sparse Cholesky preconditioner's costs and counts (factorizations, failures, fill),
    /// when the scene uses it.
    #[cfg(feature = "direct")]
    pub fn cholesky_info(&self) -> Option<&crate::linear::direct::CholeskyInfo> {
        self.newton.cholesky_info()
    }

    /// Kinetic energy ½ vᵀMv, J.
    pub fn kinetic_energy(&self) -> f64 {
        0.5 * self
            .body
            .masses()
            .iter()
            .zip(&self.state.v)
            .map(|(m, v)| m * v.norm_squared())
            .sum::<f64>()
    }

    /// Gravitational potential −Σ m g·x of the current state, J (quasistatic: of the gravity
    /// ramped to the current load factor).
    pub fn gravitational_energy(&self) -> f64 {
        let scale = if self.params.integrator.is_dynamic() {
            1.0
        } else {
            self.state.t
        };
        crate::audit::gravitational_energy(&self.body, self.boundary.gravity * scale, &self.state.x)
    }

    /// Advance one frame (all its substeps), retrying with smaller steps as the failure policy
    /// allows. A frame that cannot produce a finite state is an error; under `Stop`, so is one
    /// that does not converge. The state is untouched by a frame that errors.
    pub fn step(&mut self) -> Result<StepStats> {
        let frame = self.frame + 1;
        let started = Instant::now();
        if let Some(driver) = &mut self.driver {
            let stats = driver.step(&mut self.state)?;
            self.frame = frame;
            return Ok(stats);
        }
        let moved = self.ledger_x != self.state.x;
        if moved {
            // Moved from outside: the scheme's history is not this state's.
            self.history.clear();
        }
        self.saved.clone_from(&self.state);
        self.saved_history.clone_from(&self.history);
        let recovery_changed = self.update_recovery(moved || self.frame == 0);
        if moved || recovery_changed {
            let ranks = self.newton.ranks().cloned();
            self.ledger = initial_ledger(
                &self.body,
                &self.boundary,
                &self.free,
                &self.state.x,
                ranks.as_deref(),
            );
            self.ledger.added = self.added_energy_now();
        }
        self.saved_ledger.clone_from(&self.ledger);
        let mut attempt = 0;
        let mut stats = loop {
            if self.newton.interrupted() {
                self.back_to_frame_start();
                return Err(Error::Interrupted { frame });
            }
            let substeps = self.params.substeps << attempt;
            let retry_possible =
                self.params.on_failure == OnFailure::Retry && attempt < self.params.max_step_cuts;
            let stop_early = retry_possible || self.params.on_failure == OnFailure::Stop;
            self.newton.set_last_resort(!retry_possible);
            self.blocked = false;
            let (stats, finite) = self.advance(frame, substeps, stop_early);
            if self.newton.interrupted() {
                self.back_to_frame_start();
                return Err(Error::Interrupted { frame });
            }
            if stats.converged && finite {
                break stats;
            }
            let reason = stats
                .failure
                .clone()
                .unwrap_or_else(|| "the state became non-finite".into());
            if retry_possible {
                log::warn!(
                    "frame {frame}: {reason}; retrying with {} substeps",
                    substeps * 2
                );
                self.back_to_frame_start();
                attempt += 1;
                continue;
            }
            let inverted = if finite {
                crate::diagnose::describe_inverted(&self.body, &self.state.x)
                    .map(|d| format!("; {d}"))
                    .unwrap_or_default()
            } else {
                String::new()
            };
            if self.blocked {
                // The obstacle's prescribed motion cannot be followed: it would pass through
                // the body (caught against another obstacle, or pushed faster than it can
                // deform). Going on would put the obstacle inside the body at the next frame.
                self.back_to_frame_start();
                return Err(Error::Solve {
                    frame,
                    message: format!(
                        "{reason}, even in {substeps} substeps: the body is caught between it and \
                         another obstacle, or cannot get out of its way as fast as it moves, so \
                         its prescribed motion cannot be followed. Slow the motion down (a longer \
                         duration), stop it before it closes the gap, or use a smaller dt"
                    ),
                });
            }
            if self.params.on_failure == OnFailure::Stop || !finite {
                self.back_to_frame_start();
                return Err(Error::Solve {
                    frame,
                    message: format!("{reason}{inverted}. {ADVICE}"),
                });
            }
            log::warn!(
                "frame {frame} did not converge ({reason}{inverted}); continuing with its best iterate"
            );
            break stats;
        };
        let deformation = self.body.deformation_stats(&self.state.x);
        stats.time = self.state.t;
        stats.kinetic_energy = self.kinetic_energy();
        stats.min_j = deformation.min_j;
        stats.inverted_elements = deformation.inverted;
        stats.tangled_elements = self.tangled_total;
        if let Some(ranks) = self.newton.ranks() {
            let mut sums = [stats.kinetic_energy, stats.inverted_elements as f64];
            ranks.sum(&mut sums);
            let mut least = [-stats.min_j];
            ranks.max(&mut least);
            stats.kinetic_energy = sums[0];
            stats.inverted_elements = sums[1] as usize;
            stats.min_j = -least[0];
        }
        stats.wall_seconds = started.elapsed().as_secs_f64();
        self.inverted_at_end = stats.inverted_elements;
        self.ledger_x.clone_from(&self.state.x);
        self.frame = frame;
        Ok(stats)
    }

    /// Undo a frame's attempt: the state, the audit's ledger and the scheme's history as they
    /// were at the frame's start.
    fn back_to_frame_start(&mut self) {
        self.state.clone_from(&self.saved);
        self.ledger.clone_from(&self.saved_ledger);
        self.history.clone_from(&self.saved_history);
    }

    /// Run `substeps` steps of the frame; returns the stats and whether the state is finite.
    fn advance(&mut self, frame: usize, substeps: usize, stop_early: bool) -> (StepStats, bool) {
        let mut stats = StepStats {
            frame,
            converged: true,
            substeps,
            ..Default::default()
        };
        let params = self.frame_params().into_owned();
        let p = &params;
        let ramp_frames = self.ramp_frames.unwrap_or(p.frames);
        for i in 1..=substeps {
            let (clock, kind_is_dynamic, h, t) = if p.integrator.is_dynamic() {
                let h = p.dt / substeps as f64;
                let t = (frame - 1) as f64 * p.dt + i as f64 * h;
                let clock = Clock::Time {
                    time: t,
                    run_duration: p.dt * ramp_frames as f64,
                };
                (clock, true, h, t)
            } else {
                let s = ((frame - 1) as f64 + i as f64 / substeps as f64) / ramp_frames as f64;
                (Clock::LoadFactor(s), false, 0.0, s)
            };
            // The clock where the step starts (the ramps and loads there).
            let start_clock = match clock {
                Clock::Time { time, run_duration } => Clock::Time {
                    time: time - h,
                    run_duration,
                },
                Clock::LoadFactor(s) => {
                    Clock::LoadFactor(s - 1.0 / (substeps * ramp_frames) as f64)
                }
            };
            if self.boundary.has_releases() {
                self.boundary.fill_free_mask(Some(&clock), &mut self.free);
            }
            self.xn.copy_from_slice(&self.state.x);
            self.vn.copy_from_slice(&self.state.v);
            if kind_is_dynamic {
                if self.history.needs_acceleration(p.integrator, self.xn.len()) {
                    let a = self.start_acceleration(&start_clock);
                    self.history.set_acceleration(a);
                }
                let predicted = self.history.plan(p.integrator, &self.xn, &self.vn, h);
                self.state.x.copy_from_slice(predicted);
            }
            self.boundary
                .prescribe(&clock, &self.initial, &mut self.state.x);
            self.boundary
                .external_forces(&clock, self.body.masses(), &mut self.f_ext);
            let start = StepStart {
                xn: &self.xn,
                h: if kind_is_dynamic { h } else { 1.0 },
                ramp_start: &|duration| start_clock.ramp(duration),
                ramp_end: &|duration| clock.ramp(duration),
                free: &self.free,
            };
            self.newton
                .potential_mut()
                .begin_step(&start, &mut self.state.x);
            let kind = if kind_is_dynamic {
                StepKind::Dynamic(self.history.inertial(&self.xn, &self.vn))
            } else {
                StepKind::Static
            };
            let ctx = StepContext {
                body: &self.body,
                kind,
                f_ext: &self.f_ext,
                free: &self.free,
                params: p,
            };
            let mut info = self
                .newton
                .solve(&ctx, &mut self.state.x, &mut self.state.v);
            if self.newton.interrupted() {
                stats.converged = false;
                return (stats, true);
            }
            // A term may move itself on and ask for the step again (moving obstacles pushing
            // the body out of their way, until they arrive).
            while info.converged {
                match self.newton.potential_mut().continue_step(&self.state.x) {
                    Ok(false) => break,
                    Ok(true) => {}
                    Err(why) => {
                        info.converged = false;
                        info.failure = Some(why);
                        self.blocked = true;
                        break;
                    }
                }
                let mut more = self
                    .newton
                    .solve(&ctx, &mut self.state.x, &mut self.state.v);
                if self.newton.interrupted() {
                    stats.converged = false;
                    return (stats, true);
                }
                // Each new solve starts near the last equilibrium; its tolerance is the step's
                // (relative to the first solve's first residual), not a fraction of its own
                // small start.
                let reference = info.history.first().copied().unwrap_or(0.0);
                if !more.converged
                    && more.residual.is_finite()
                    && more.residual <= self.params.newton_tolerance * reference
                {
                    more.converged = true;
                    more.failure = None;
                }
                info.then(more);
            }
            if info.converged
                && let Some(reason) = self.step_violation()
            {
                info.converged = false;
                info.failure = Some(reason);
            }
            stats.absorb(&info);
            self.newton.potential().add_stats(&mut stats);
            self.state.t = t;
            let mut finite = self
                .state
                .x
                .iter()
                .chain(&self.state.v)
                .all(|p| p.iter().all(|c| c.is_finite()));
            if let Some(ranks) = self.newton.ranks() {
                let mut broken = [if finite { 0.0 } else { 1.0 }];
                ranks.max(&mut broken);
                finite = broken[0] == 0.0;
            }
            if !finite {
                return (stats, false);
            }
            let elastic = info.elastic_energy;
            let gravity = self.boundary.gravity * clock.gravity_scale();
            stats.energy.add(&self.audit_substep(
                elastic,
                gravity,
                kind_is_dynamic,
                (p.rayleigh_stiffness, p.rayleigh_mass),
            ));
            self.history.finish(
                p.integrator,
                &self.xn,
                &self.vn,
                &self.state.x,
                &self.state.v,
            );
            if !info.converged && stop_early {
                break;
            }
        }
        (stats, true)
    }
}

/// The audit's ledger at the initial state: its elastic energy and, for the quasistatic trapezoid
/// rule, the loads (zero at load factor 0) and reactions there.
/// Under MPI (`ranks`) the forces are completed over the ranks and the energy is this rank's
/// share (the audit sums it).
fn initial_ledger(
    body: &ElasticBody,
    boundary: &Boundary,
    free: &[Vec3],
    x: &[Vec3],
    ranks: Option<&dyn crate::parallel::Ranks>,
) -> Ledger {
    let n = body.vertex_count();
    let mut loads = vec![Vec3::zeros(); n];
    boundary.external_forces(&Clock::LoadFactor(0.0), body.masses(), &mut loads);
    let mut forces = vec![Vec3::zeros(); n];
    body.add_forces(x, &mut forces);
    if let Some(ranks) = ranks {
        crate::parallel::complete_vectors(ranks, &mut forces);
    }
    let reactions = forces
        .iter()
        .zip(&loads)
        .zip(free)
        .map(|((f, l), m)| -(f + l).component_mul(&(Vec3::repeat(1.0) - m)))
        .collect();
    Ledger {
        elastic: body.energy(x),
        loads,
        reactions,
        forces,
        damping: Vec::new(),
        added: 0.0,
    }
}

/// What to try when a frame fails, appended to the error.
const ADVICE: &str = "Try more substeps or a smaller dt ([solver] substeps, dt), \
on_failure = \"retry\" to cut the step automatically, a looser newton_tolerance, \
or more newton_max_iterations / cg_max_iterations";

/// Reject solver settings that cannot work, with the scene key in the message.
fn check_params(p: &SolverParams) -> Result<()> {
    let positive = |name: &str, value: f64| {
        if value > 0.0 && value.is_finite() {
            Ok(())
        } else {
            Err(Error::parameter(
                format!("solver.{name}"),
                format!("must be positive and finite, got {value}"),
            ))
        }
    };
    positive("dt", p.dt)?;
    positive("newton_tolerance", p.newton_tolerance)?;
    positive("cg_tolerance", p.cg.tolerance)?;
    for (name, value) in [
        ("rayleigh_stiffness", p.rayleigh_stiffness),
        ("rayleigh_mass", p.rayleigh_mass),
    ] {
        if !(value >= 0.0 && value.is_finite()) {
            return Err(Error::parameter(
                format!("solver.{name}"),
                format!("must be zero or positive, got {value}"),
            ));
        }
    }
    for (name, value) in [
        ("substeps", p.substeps),
        ("newton_max_iterations", p.newton_max_iterations),
        ("cg_max_iterations", p.cg.max_iterations),
    ] {
        if value == 0 {
            return Err(Error::parameter(
                format!("solver.{name}"),
                "must be at least 1",
            ));
        }
    }
    if p.max_step_cuts > 20 {
        return Err(Error::parameter(
            "solver.max_step_cuts",
            "must be at most 20 (2²⁰ substeps)",
        ));
    }
    Ok(())
}
