//! `tetsim bench`: the benchmark cantilever workload at several mesh sizes, with the figures that
//! say where time goes and how close the linear solve runs to the memory-bandwidth roof.
//!
//! Workload (fixed so figures compare across versions and with other codes): beam
//! `[0,4]×[0,1]×[0,1]` m of 4n×n×n Kuhn cubes, x = 0 fixed, gravity (0, −9.81, 0), ρ = 1000,
//! Neo-Hookean E = 1e6 Pa, ν = 0.3, Rayleigh γ = 0.01, h = 1/30 s, Newton relative tolerance
//! 1e-4. Bytes per CG iteration are a model of the traffic (operator data once per product plus
//! the CG vector passes), documented at [`cg_vector_bytes_per_vertex`]; achieved GB/s divides it by
//! the measured CG time, and the roofline ratio compares that with a STREAM triad measured in the
//! same process.

mod roofline;
mod whole;

pub use roofline::{cg_vector_bytes_per_vertex, phase_bytes_per_tet, stream_triad};
use std::time::Instant;
pub use whole::{WholeRun, whole_run};

use serde::Serialize;

use crate::error::Result;
use crate::mesh::ordering::VertexOrder;
use crate::scene::Scene;
use crate::sim::Simulation;

/// What to run.
#[derive(Clone, Debug)]
pub struct BenchParams {
    /// Mesh sizes n (4n×n×n cubes).
    pub sizes: Vec<usize>,
    /// Frames per run (the workload has 30).
    pub frames: usize,
    /// Runs per size; the median is reported.
    pub repeats: usize,
    /// Extra `[solver]` lines appended to the workload scene (e.g. `preconditioner = "amg"`).
    pub solver_overrides: String,
    /// Internal vertex order (`[mesh] reorder`); `random` measures a badly numbered mesh.
    pub reorder: VertexOrder,
    /// Element order of the beam workload (`[mesh] order`): 1 (linear tets) or 2 (quadratic).
    pub order: u8,
    /// The contact workload: the same beam drooping onto a ground plane 0.5 mm below it
    /// (friction 0.3), contact active from the first frame.
    pub contact: bool,
    /// Which scene: the cantilever (default) or a Contact II workload.
    pub workload: Workload,
    /// Also run each size once whole, with the default outputs (see [`whole_run`]).
    pub whole: bool,
}

/// The scenes `tetsim bench` times.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Workload {
    /// The benchmark cantilever, 4n×n×n cubes (24n³ tets); `--contact` adds a ground plane.
    #[default]
    Beam,
    /// Three soft blocks of n×n/2×n cubes stacked on the ground (9n³ tets; body–body contact):
    /// `scenes/stack.toml` at size n. n = 18: 52k tets, n = 28: 198k.
    Stack,
    /// A beam of 16n×n×n cubes (96n³ tets) clamped at both ends, the right end turned four
    /// times and moved in by a fifth over 2 s (200 frames of 0.01 s; self-contact once it coils,
    /// so time it with `--frames 250`):
    /// `scenes/coil.toml` at size n. n = 8: 49k tets, n = 13: 211k.
    Coil,
}

impl Workload {
    /// The name `--workload` takes.
    pub fn name(self) -> &'static str {
        match self {
            Workload::Beam => "beam",
            Workload::Stack => "stack",
            Workload::Coil => "coil",
        }
    }

    /// The workload named `name`.
    pub fn from_name(name: &str) -> Option<Self> {
        [Workload::Beam, Workload::Stack, Workload::Coil]
            .into_iter()
            .find(|w| w.name() == name)
    }
}

impl Default for BenchParams {
    fn default() -> Self {
        BenchParams {
            sizes: vec![6, 12, 20],
            frames: 30,
            repeats: 3,
            solver_overrides: String::new(),
            reorder: VertexOrder::default(),
            order: 1,
            contact: false,
            workload: Workload::Beam,
            whole: true,
        }
    }
}

/// Figures for one mesh size.
#[derive(Clone, Debug, Serialize)]
pub struct SizeReport {
    /// n.
    pub n: usize,
    /// Tets.
    pub tets: usize,
    /// Vertices.
    pub vertices: usize,
    /// Median over repeats of the mean wall seconds per frame.
    pub seconds_per_frame: f64,
    /// Fastest repeat's seconds per frame.
    pub seconds_per_frame_min: f64,
    /// Newton iterations per frame.
    pub newton_per_frame: f64,
    /// CG iterations per Newton iteration.
    pub cg_per_newton: f64,
    /// Share of the time in forces and tangents (SVDs).
    pub share_evaluate: f64,
    /// Share in preconditioner setup and matrix assembly.
    pub share_preconditioner: f64,
    /// Share in CG.
    pub share_cg: f64,
    /// Everything else (output is not written by the bench).
    pub share_other: f64,
    /// CG seconds per iteration per tet, in ns.
    pub ns_per_tet_per_cg_iteration: f64,
    /// Modelled bytes moved per tet per CG iteration.
    pub bytes_per_tet_per_cg_iteration: f64,
    /// Those bytes over the measured CG time, GB/s.
    pub achieved_gb_per_s: f64,
    /// achieved / STREAM triad.
    pub roofline_ratio: f64,
    /// Resident memory at the end of the run, MB.
    pub resident_mb: f64,
    /// The same per tet, bytes.
    pub resident_bytes_per_tet: f64,
    /// Where the memory goes at the end of the first run: the large buffers counted by part
    /// (see [`Simulation::memory_inventory`]).
    pub memory: crate::memory::Inventory,
    /// Evaluation (SVDs, stresses, forces, tangents) per tet per Newton iteration, ns.
    pub ns_per_tet_per_newton_evaluate: f64,
    /// Assembly and the AMG set-up or refresh per tet per Newton iteration, ns.
    pub ns_per_tet_per_newton_preconditioner: f64,
    /// CG per tet per Newton iteration, ns.
    pub ns_per_tet_per_newton_cg: f64,
    /// Modelled bytes the evaluation moves per tet per Newton iteration (see
    /// [`phase_bytes_per_tet`]).
    pub bytes_per_tet_per_newton_evaluate: f64,
    /// Modelled bytes the assembly moves per tet per Newton iteration (AMG refreshes not
    /// counted; see [`phase_bytes_per_tet`]).
    pub bytes_per_tet_per_newton_assembly: f64,
    /// The beam workloads: the mean displacement of the tip face (the vertices at x = 4 m) after
    /// the first run, m: the answer, for comparing versions and settings (other codes' figures,
    /// measured elsewhere, are in docs/performance.md with where and when).
    pub tip_displacement: Option<[f64; 3]>,
    /// Whether every frame converged.
    pub all_converged: bool,
    /// The sparse Cholesky's figures, when it is the preconditioner (feature `direct`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub factor: Option<FactorReport>,
    /// Contact's costs, in the contact workload.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub contact: Option<ContactReport>,
    /// The whole run with its outputs (pictures off), once.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub whole: Option<WholeRun>,
}

/// What contact cost in the first run of a size (the contact workload).
#[derive(Clone, Debug, Serialize)]
pub struct ContactReport {
    /// Active contact pairs at the end of the run.
    pub active_pairs: usize,
    /// Broad phase plus barrier, ns per primitive pair examined.
    pub ns_per_pair_barrier: f64,
    /// Of which the broad phase, ns per pair examined (0 for planes: no broad phase).
    pub ns_per_pair_broad: f64,
    /// CCD, ns per surface primitive per line-search bound.
    pub ns_per_primitive_ccd: f64,
    /// Share of the run's wall time in contact (broad phase, barrier, CCD).
    pub share: f64,
    /// Seconds per frame in the broad phase.
    pub broad_seconds_per_frame: f64,
    /// Seconds per frame evaluating and assembling barrier and friction pairs.
    pub barrier_seconds_per_frame: f64,
    /// Seconds per frame in CCD.
    pub ccd_seconds_per_frame: f64,
    /// Seconds per frame in the linear solves (preconditioner set-up, assembly and CG).
    pub solve_seconds_per_frame: f64,
    /// Peak resident memory of the process so far, MB.
    pub peak_mb: f64,
    /// Pairs between body primitives (self-contact, body–body) examined per evaluation.
    pub body_pairs_per_evaluation: f64,
    /// Their broad phase, ns per pair examined.
    pub ns_per_body_pair_broad: f64,
    /// Their barrier (distances, derivatives within d̂), ns per pair examined.
    pub ns_per_body_pair_barrier: f64,
    /// Their CCD (broad phase over swept boxes included), ns per pair tested.
    pub ns_per_body_pair_ccd: f64,
    /// Searches of the surface's tree for body pairs per frame (evaluations and CCD bounds
    /// otherwise reuse the list kept from the last search).
    pub body_searches_per_frame: f64,
}

/// What the sparse Cholesky preconditioner cost in the first run of a size.
#[derive(Clone, Debug, Serialize)]
pub struct FactorReport {
    /// Numeric factorizations per frame.
    pub factorizations_per_frame: f64,
    /// Factorizations that failed (A not positive definite).
    pub failures: usize,
    /// Mean seconds per numeric factorization.
    pub seconds_per_factorization: f64,
    /// Seconds of the one symbolic analysis.
    pub symbolic_seconds: f64,
    /// Entries of A's upper triangle.
    pub a_nonzeros: usize,
    /// Entries of the factor L.
    pub l_nonzeros: usize,
}

/// The whole bench.
#[derive(Clone, Debug, Serialize)]
pub struct BenchReport {
    /// tetsim version.
    pub version: String,
    /// Worker threads.
    pub threads: usize,
    /// STREAM triad bandwidth, GB/s (best of 5, all threads).
    pub stream_triad_gb_per_s: f64,
    /// Per size.
    pub sizes: Vec<SizeReport>,
    /// The solver overrides used.
    pub solver_overrides: String,
    /// The vertex order used.
    pub reorder: VertexOrder,
    /// The element order of the beam (1 or 2).
    pub order: u8,
    /// The scene timed.
    pub workload: Workload,
}

/// The workload scene for size n.
pub fn workload_scene(
    n: usize,
    frames: usize,
    solver_overrides: &str,
    reorder: VertexOrder,
    order: u8,
) -> Result<Scene> {
    let text = format!(
        r#"
gravity = [0.0, -9.81, 0.0]
[mesh]
generator = {{ box = {{ min = [0.0, 0.0, 0.0], max = [4.0, 1.0, 1.0], cells = [{}, {n}, {n}] }} }}
reorder = "{}"
order = {order}
[material]
model = "neo-hookean"
youngs_modulus = 1.0e6
poisson_ratio = 0.3
density = 1000.0
[[fixed]]
region = {{ box = {{ min = [-0.001, -1.0, -1.0], max = [0.001, 2.0, 2.0] }} }}
[solver]
dt = 0.033333333333333333
frames = {frames}
rayleigh_stiffness = 0.01
newton_tolerance = 1e-4
{solver_overrides}
"#,
        4 * n,
        reorder.name()
    );
    Scene::parse(
        &text,
        std::path::Path::new("<bench workload>"),
        std::path::Path::new("."),
    )
}

/// The workload with a ground plane 0.5 mm under the beam (friction 0.3).
fn with_ground(scene: Scene) -> Result<Scene> {
    let text = format!(
        "{}\n[[obstacle]]\nname = \"ground\"\nplane = {{ point = [0.0, -0.0005, 0.0], normal = [0.0, 1.0, 0.0] }}\nfriction = 0.3\n",
        scene.source()
    );
    Scene::parse(
        &text,
        std::path::Path::new("<bench contact workload>"),
        std::path::Path::new("."),
    )
}

/// Three soft blocks stacked on the ground at size n (see [`Workload::Stack`]).
fn stack_scene(n: usize, frames: usize, solver_overrides: &str) -> Result<Scene> {
    let text = stack_text(n, frames, solver_overrides);
    Scene::parse(
        &text,
        std::path::Path::new("<bench stack workload>"),
        std::path::Path::new("."),
    )
}

fn stack_text(n: usize, frames: usize, solver_overrides: &str) -> String {
    let half = (n / 2).max(1);
    let block = |name: &str, size: f64, y: f64, degrees: f64, e: f64| {
        format!(
            "[[body]]\nname = \"{name}\"\nmesh = {{ generator = {{ box = {{ min = [{lo}, 0.0, {lo}], max = [{hi}, {h}, {hi}], cells = [{n}, {half}, {n}] }} }} }}\nmaterial = {{ youngs_modulus = {e}, poisson_ratio = 0.4, density = 1000.0 }}\nrotate_degrees = {degrees}\naxis = [0.0, 1.0, 0.0]\ntranslate = [0.0, {y}, 0.0]\n",
            lo = -size / 2.0,
            hi = size / 2.0,
            h = size * (half as f64 / n as f64),
        )
    };
    format!(
        r#"
gravity = [0.0, -9.81, 0.0]
[mesh]
name = "bottom"
generator = {{ box = {{ min = [-0.15, 0.0, -0.15], max = [0.15, {h0}, 0.15], cells = [{n}, {half}, {n}] }} }}
[material]
youngs_modulus = 1e5
poisson_ratio = 0.4
density = 1000.0
{middle}{top}
[[obstacle]]
name = "ground"
plane = {{ point = [0.0, -0.001, 0.0], normal = [0.0, 1.0, 0.0] }}
[contact]
friction = 0.5
[solver]
dt = 0.01
frames = {frames}
rayleigh_mass = 2.0
{solver_overrides}
"#,
        h0 = 0.3 * (half as f64 / n as f64),
        middle = block(
            "middle",
            0.24,
            0.3 * (half as f64 / n as f64) + 0.005,
            20.0,
            5e4
        ),
        top = block(
            "top",
            0.18,
            (0.3 + 0.24) * (half as f64 / n as f64) + 0.01,
            40.0,
            2.5e4
        ),
    )
}

/// A beam twisted into a coil at size n (see [`Workload::Coil`]).
fn coil_scene(n: usize, frames: usize, solver_overrides: &str) -> Result<Scene> {
    // As scenes/coil.toml: the twist takes 2 s at 0.01 s per frame, so the turns touch from
    // about frame 150 on (`--frames 250` times the coiled beam).
    let dt = 0.01;
    let text = format!(
        r#"
gravity = [0.0, 0.0, 0.0]
[mesh]
generator = {{ box = {{ min = [0.0, -0.03, -0.03], max = [1.0, 0.03, 0.03], cells = [{nx}, {n}, {n}] }} }}
[material]
youngs_modulus = 1e6
poisson_ratio = 0.3
density = 1000.0
[[fixed]]
region = {{ physical = "xmin" }}
[[fixed]]
region = {{ physical = "xmax" }}
motion = {{ rotate_degrees = 1440.0, axis = [1.0, 0.0, 0.0], center = [1.0, 0.0, 0.0], translate = [-0.2, 0.0, 0.0] }}
duration = {duration}
[contact]
friction = 0.0
[solver]
dt = {dt}
frames = {frames}
rayleigh_mass = 5.0
newton_max_iterations = 200
{solver_overrides}
"#,
        nx = 16 * n,
        duration = 2.0,
    );
    Scene::parse(
        &text,
        std::path::Path::new("<bench coil workload>"),
        std::path::Path::new("."),
    )
}

/// Start [`peak_resident_mb`] afresh (Linux ≥ 4.0: writing 5 to clear_refs resets the peak;
/// elsewhere nothing happens and the peak counts from the start of the process).
fn reset_peak_resident() {
    let _ = std::fs::write("/proc/self/clear_refs", "5");
}

/// Peak resident memory of this process since [`reset_peak_resident`], MB (Linux; 0
/// elsewhere).
pub fn peak_resident_mb() -> f64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("VmHWM:"))
                .and_then(|l| l.split_whitespace().nth(1))
                .and_then(|kb| kb.parse::<f64>().ok())
        })
        .map_or(0.0, |kb| kb / 1024.0)
}

/// Contact's figures of a finished run of `seconds` over `frames` frames, whose linear solves
/// took `solve_seconds`.
fn contact_report(
    sim: &Simulation,
    seconds: f64,
    frames: usize,
    solve_seconds: f64,
) -> Option<ContactReport> {
    let contact = sim.contact()?;
    let costs = contact.costs();
    let surface = crate::contact::surface::ContactSurface::from_mesh(&sim.body.mesh);
    let primitives = surface.vertices.len().max(1) as f64;
    let examined = costs.pairs_examined.max(1) as f64;
    let per = frames.max(1) as f64;
    let body_examined = costs.body_pairs_examined.max(1) as f64;
    Some(ContactReport {
        active_pairs: contact.active_pairs(),
        ns_per_pair_barrier: (costs.broad_seconds + costs.barrier_seconds) / examined * 1e9,
        ns_per_pair_broad: costs.broad_seconds / examined * 1e9,
        ns_per_primitive_ccd: costs.ccd_seconds / (costs.ccd_calls.max(1) as f64 * primitives)
            * 1e9,
        share: (costs.broad_seconds + costs.barrier_seconds + costs.ccd_seconds) / seconds,
        broad_seconds_per_frame: costs.broad_seconds / per,
        barrier_seconds_per_frame: costs.barrier_seconds / per,
        ccd_seconds_per_frame: costs.ccd_seconds / per,
        solve_seconds_per_frame: solve_seconds / per,
        peak_mb: peak_resident_mb(),
        body_pairs_per_evaluation: costs.body_pairs_examined as f64
            / costs.evaluations.max(1) as f64,
        ns_per_body_pair_broad: costs.body_broad_seconds / body_examined * 1e9,
        ns_per_body_pair_barrier: costs.body_barrier_seconds / body_examined * 1e9,
        ns_per_body_pair_ccd: costs.body_ccd_seconds / costs.body_ccd_pairs.max(1) as f64 * 1e9,
        body_searches_per_frame: costs.body_searches as f64 / per,
    })
}

/// Resident set size of this process, MB (Linux; 0 elsewhere).
pub fn resident_mb() -> f64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("VmRSS:"))
                .and_then(|l| l.split_whitespace().nth(1))
                .and_then(|kb| kb.parse::<f64>().ok())
        })
        .map_or(0.0, |kb| kb / 1024.0)
}

fn median(values: &mut [f64]) -> f64 {
    values.sort_by(f64::total_cmp);
    let m = values.len() / 2;
    if values.len() % 2 == 1 {
        values[m]
    } else {
        0.5 * (values[m - 1] + values[m])
    }
}

/// Run the bench; `progress` hears one line per finished run.
pub fn run(params: &BenchParams, mut progress: impl FnMut(&str)) -> Result<BenchReport> {
    let stream = stream_triad();
    progress(&format!("STREAM triad: {stream:.1} GB/s"));
    let mut sizes = Vec::new();
    for &n in &params.sizes {
        let scene = match params.workload {
            Workload::Beam => {
                let scene = workload_scene(
                    n,
                    params.frames,
                    &params.solver_overrides,
                    params.reorder,
                    params.order,
                )?;
                if params.contact {
                    with_ground(scene)?
                } else {
                    scene
                }
            }
            Workload::Stack => stack_scene(n, params.frames, &params.solver_overrides)?,
            Workload::Coil => coil_scene(n, params.frames, &params.solver_overrides)?,
        };
        let mut per_frame = Vec::new();
        let (mut newton, mut cg, mut frames, mut cuts) = (0usize, 0usize, 0usize, 0usize);
        let mut timings = crate::integrator::Timings::default();
        let mut wall = 0.0;
        let mut all_converged = true;
        let mut report_mem = 0.0;
        let mut memory = crate::memory::Inventory::default();
        let (mut tets, mut vertices, mut operator_bytes_per_tet) = (0, 0, 0.0);
        let mut factor = None;
        let mut contact = None;
        let mut tip = None;
        for repeat in 0..params.repeats {
            if repeat == 0 {
                reset_peak_resident();
            }
            let mut sim = Simulation::from_scene(&scene)?;
            tets = sim.body.tet_count();
            vertices = sim.body.vertex_count();
            let started = Instant::now();
            while !sim.is_finished() {
                let stats = sim.step()?;
                all_converged &= stats.converged;
                if repeat == 0 {
                    newton += stats.newton_iterations;
                    cg += stats.cg_iterations;
                    frames += 1;
                    cuts += stats.line_search_cuts;
                    timings.add(&stats.timings);
                }
            }
            let seconds = started.elapsed().as_secs_f64();
            // After the run: the assembled path knows its matrices' sizes only once built.
            operator_bytes_per_tet = sim.operator_bytes_per_product() / tets as f64;
            if repeat == 0 {
                wall = seconds;
                report_mem = resident_mb();
                memory = sim.memory_inventory();
                factor = factor_report(&sim, params.frames);
                if params.workload == Workload::Beam {
                    tip = Some(tip_displacement(&sim));
                }
                contact = contact_report(
                    &sim,
                    seconds,
                    params.frames,
                    timings.preconditioner + timings.cg,
                );
            }
            per_frame.push(seconds / params.frames as f64);
            progress(&format!(
                "n = {n}: run {} of {}: {:.3} s/frame",
                repeat + 1,
                params.repeats,
                seconds / params.frames as f64
            ));
        }
        let whole = if params.whole {
            let w = whole_run(&scene)?;
            progress(&format!(
                "n = {n}: whole run: {:.3} s/frame, {:.2}x its steps",
                w.seconds_per_frame, w.ratio
            ));
            Some(w)
        } else {
            None
        };
        let fastest = per_frame.iter().copied().fold(f64::INFINITY, f64::min);
        let seconds_per_frame = median(&mut per_frame);
        let cg_seconds = timings.cg;
        let bytes_per_tet =
            operator_bytes_per_tet + cg_vector_bytes_per_vertex() * vertices as f64 / tets as f64;
        let achieved = bytes_per_tet * tets as f64 * cg as f64 / cg_seconds.max(1e-12) / 1e9;
        let per_newton_tet = 1e9 / (newton.max(1) as f64 * tets.max(1) as f64);
        let force_passes = (newton + frames + cuts) as f64 / newton.max(1) as f64;
        let (evaluate_bytes, assembly_bytes) = phase_bytes_per_tet(&memory, force_passes, tets);
        sizes.push(SizeReport {
            n,
            tets,
            vertices,
            seconds_per_frame,
            seconds_per_frame_min: fastest,
            newton_per_frame: newton as f64 / frames.max(1) as f64,
            cg_per_newton: cg as f64 / newton.max(1) as f64,
            share_evaluate: timings.evaluate / wall,
            share_preconditioner: timings.preconditioner / wall,
            share_cg: timings.cg / wall,
            share_other: (1.0 - (timings.evaluate + timings.preconditioner + timings.cg) / wall)
                .max(0.0),
            ns_per_tet_per_cg_iteration: cg_seconds / (cg.max(1) as f64 * tets as f64) * 1e9,
            bytes_per_tet_per_cg_iteration: bytes_per_tet,
            achieved_gb_per_s: achieved,
            roofline_ratio: achieved / stream,
            resident_mb: report_mem,
            resident_bytes_per_tet: report_mem * 1024.0 * 1024.0 / tets.max(1) as f64,
            memory,
            ns_per_tet_per_newton_evaluate: timings.evaluate * per_newton_tet,
            ns_per_tet_per_newton_preconditioner: timings.preconditioner * per_newton_tet,
            ns_per_tet_per_newton_cg: timings.cg * per_newton_tet,
            bytes_per_tet_per_newton_evaluate: evaluate_bytes,
            bytes_per_tet_per_newton_assembly: assembly_bytes,
            tip_displacement: tip,
            all_converged,
            factor,
            contact,
            whole,
        });
    }
    Ok(BenchReport {
        version: env!("CARGO_PKG_VERSION").to_string(),
        threads: rayon::current_num_threads(),
        stream_triad_gb_per_s: stream,
        sizes,
        solver_overrides: params.solver_overrides.clone(),
        reorder: params.reorder,
        order: params.order,
        workload: params.workload,
    })
}

/// The mean displacement of the vertices on the beam's far face (largest rest x), m.
fn tip_displacement(sim: &Simulation) -> [f64; 3] {
    let rest = &sim.body.mesh.positions;
    let far = rest.iter().map(|p| p.x).fold(f64::NEG_INFINITY, f64::max);
    let (mut sum, mut count) = (crate::math::Vec3::zeros(), 0usize);
    for (x, r) in sim.state.x.iter().zip(rest) {
        if r.x >= far - 1e-9 * far.abs().max(1.0) {
            sum += x - r;
            count += 1;
        }
    }
    let mean = sum / count.max(1) as f64;
    [mean.x, mean.y, mean.z]
}

/// The Cholesky figures of a finished run, if it used the Cholesky preconditioner.
fn factor_report(sim: &Simulation, frames: usize) -> Option<FactorReport> {
    #[cfg(feature = "direct")]
    {
        sim.cholesky_info().map(|info| FactorReport {
            factorizations_per_frame: info.factorizations as f64 / frames as f64,
            failures: info.failures,
            seconds_per_factorization: info.factor_seconds / info.factorizations.max(1) as f64,
            symbolic_seconds: info.symbolic_seconds,
            a_nonzeros: info.a_nonzeros,
            l_nonzeros: info.l_nonzeros,
        })
    }
    #[cfg(not(feature = "direct"))]
    {
        let _ = (sim, frames);
        None
    }
}

impl BenchReport {
    /// The human-readable table.
    pub fn table(&self) -> String {
        let mut s = format!(
            "tetsim {} bench, {} threads, STREAM triad {:.1} GB/s, vertex order {}{}{}\n",
            self.version,
            self.threads,
            self.stream_triad_gb_per_s,
            self.reorder.name(),
            if self.order == 2 {
                ", quadratic tets"
            } else {
                ""
            },
            if self.solver_overrides.trim().is_empty() {
                String::new()
            } else {
                format!(
                    ", solver: {}",
                    self.solver_overrides.trim().replace('\n', "; ")
                )
            }
        );
        s.push_str("   n      tets  s/frame  Newton/fr  CG/Newton  eval%  prec%   CG%  other%  ns/tet/it  B/tet/it   GB/s  roof  RSS MB  KB/tet   tip |u| m\n");
        for r in &self.sizes {
            s.push_str(&format!(
                "{:>4} {:>9} {:>8.3} {:>10.2} {:>10.1} {:>6.1} {:>6.1} {:>5.1} {:>7.1} {:>10.2} {:>9.0} {:>6.1} {:>5.2} {:>7.0} {:>7.2} {:>11}{}\n",
                r.n,
                r.tets,
                r.seconds_per_frame,
                r.newton_per_frame,
                r.cg_per_newton,
                100.0 * r.share_evaluate,
                100.0 * r.share_preconditioner,
                100.0 * r.share_cg,
                100.0 * r.share_other,
                r.ns_per_tet_per_cg_iteration,
                r.bytes_per_tet_per_cg_iteration,
                r.achieved_gb_per_s,
                r.roofline_ratio,
                r.resident_mb,
                r.resident_bytes_per_tet / 1024.0,
                r.tip_displacement.map_or("-".to_string(), |u| format!(
                    "{:.6}",
                    (u[0] * u[0] + u[1] * u[1] + u[2] * u[2]).sqrt()
                )),
                if r.all_converged { "" } else { "  (some frames did not converge)" }
            ));
            let tets = r.tets.max(1) as f64;
            let mut parts: Vec<&crate::memory::MemoryPart> = r.memory.parts.iter().collect();
            parts.sort_by_key(|p| std::cmp::Reverse(p.bytes));
            // A phase's modelled bytes over its time, against STREAM.
            let roof = |bytes: f64, ns: f64| {
                let gb_per_s = bytes / ns.max(1e-12);
                format!(
                    "{bytes:.0} B, {:.2} of STREAM",
                    gb_per_s / self.stream_triad_gb_per_s
                )
            };
            s.push_str(&format!(
                "     per Newton iteration and tet: evaluate {:.0} ns ({}), assemble+AMG {:.0} ns (assembly {}), CG {:.0} ns; buffers counted {:.0} B/tet, largest: {}\n",
                r.ns_per_tet_per_newton_evaluate,
                roof(r.bytes_per_tet_per_newton_evaluate, r.ns_per_tet_per_newton_evaluate),
                r.ns_per_tet_per_newton_preconditioner,
                roof(r.bytes_per_tet_per_newton_assembly, r.ns_per_tet_per_newton_preconditioner),
                r.ns_per_tet_per_newton_cg,
                r.memory.total() as f64 / tets,
                parts
                    .iter()
                    .take(4)
                    .map(|p| format!("{} {:.0}", p.name, p.bytes as f64 / tets))
                    .collect::<Vec<_>>()
                    .join(", ")
            ));
            if let Some(w) = &r.whole {
                s.push_str(&format!(
                    "     whole run (outputs on, pictures off): {:.3} s/frame, {:.2}x its steps' {:.3}; set-up {:.2} s, frame 0 {:.2} s, manifest {:.2} s, loop {:.2} s, end {:.2} s\n",
                    w.seconds_per_frame, w.ratio, w.step_seconds_per_frame, w.setup_seconds,
                    w.first_frame_seconds, w.manifest_seconds, w.loop_seconds, w.finish_seconds
                ));
            }
            if let Some(f) = &r.factor {
                s.push_str(&format!(
                    "     Cholesky: {:.2} factorizations/frame, {:.3} s each, symbolic {:.3} s, nnz(A upper) {}, nnz(L) {} ({:.1}×), {} failed\n",
                    f.factorizations_per_frame,
                    f.seconds_per_factorization,
                    f.symbolic_seconds,
                    f.a_nonzeros,
                    f.l_nonzeros,
                    f.l_nonzeros as f64 / f.a_nonzeros.max(1) as f64,
                    f.failures
                ));
            }
            if let Some(c) = &r.contact {
                s.push_str(&format!(
                    "     contact: {} active pairs, barrier {:.0} ns/pair (broad phase {:.0}), CCD {:.0} ns/primitive, {:.1} % of the time\n     per frame: broad phase {:.4} s, barrier {:.4} s, CCD {:.4} s, linear solves {:.4} s; peak RSS {:.0} MB\n",
                    c.active_pairs,
                    c.ns_per_pair_barrier,
                    c.ns_per_pair_broad,
                    c.ns_per_primitive_ccd,
                    100.0 * c.share,
                    c.broad_seconds_per_frame,
                    c.barrier_seconds_per_frame,
                    c.ccd_seconds_per_frame,
                    c.solve_seconds_per_frame,
                    c.peak_mb
                ));
                s.push_str(&format!(
                    "     body pairs (self-contact): {:.0} examined per evaluation, {:.1} tree searches per frame, broad phase {:.0} ns/pair, barrier {:.0} ns/pair, CCD {:.0} ns/pair\n",
                    c.body_pairs_per_evaluation,
                    c.body_searches_per_frame,
                    c.ns_per_body_pair_broad,
                    c.ns_per_body_pair_barrier,
                    c.ns_per_body_pair_ccd
                ));
            }
        }
        s
    }
}

#[cfg(test)]
mod tests;
