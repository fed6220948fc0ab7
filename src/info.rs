//! What a scene is, before running it (`tetsim info`, and the `info` object of manifest.json;
//! SPEC §13): mass, volume, bounding box, each material's moduli and wave speeds, an estimate
//! of the lowest natural frequency and the time steps that follow from it.
//!
//! **Moduli.** Read from each material's tangent at rest (∂P/∂F at F = I), so every model
//! reports the small-strain μ and λ it really uses: `λ + 2μ = ∂P₁₁/∂F₁₁`, `μ = ∂P₁₂/∂F₁₂`.
//! Wave speeds `c_p = √((λ + 2μ)/ρ)`, `c_s = √(μ/ρ)`.
//!
//! **Lowest frequency (an estimate).** Shifted subspace iteration on `K(x_rest)·φ = ω²·M·φ` over
//! the free DOFs (the lumped M, the scene's fixed conditions, the body without contact): a block
//! of three vectors, started from uniform body forces along x, y and z (each with a small
//! deterministic disturbance, so no mode is missed by symmetry), is multiplied by
//! `(K + σM)⁻¹·M` (one solve per vector with the scene's linear solver, AMG by default) and
//! reduced by Rayleigh-Ritz; the smallest Ritz value is an upper bound of ω₁² that converges
//! with (ω₁/ω₄)², fast for the usual bodies (a beam's two bendings and a twist or stretch fill
//! the block). It stops after [`MAX_ITERATIONS`] blocks or when it changes by less than 1e-4
//! (then within about 1e-7 of its limit: see [`CONVERGED`]).
//! The shift σ = 1e-5·(c_s/L)² (L the bounding-box diagonal) keeps the solves definite when the
//! constraints leave a rigid motion free; a value below σ/100 then says so ("rigid") and the
//! frequency is 0. Checked against a dense eigensolver in the tests; `tetsim modes` computes
//! every mode properly, this costs a few solves.
//!
//! **Time steps.**
//! - `backward_euler_accuracy` = T₁/20: twenty steps per period of the lowest mode resolve its
//!   motion. Backward Euler still damps it: with N steps per period the amplitude falls by
//!   `1 − (1 + (2π/N)²)^(−N/2)` per period (61 % at N = 20, 9 % at N = 200);
//!   `backward_euler_damping_per_period` is that loss at the scene's own step (dt/substeps).
//!   `amplitude_kept_per_period` is what the scene's own scheme keeps: BDF2 and Newmark are
//!   second order (Newmark's average-acceleration rule keeps it all, at the price of a period
//!   lengthened by about (ωh)²/12).
//! - `explicit_stability` = min over tets of r / c_p, r the tet's inradius (3V over its surface
//!   area): the CFL limit an explicit integrator would need (not tetsim's: backward Euler is
//!   stable at any step). A regular tet's lumped-mass limit 2/ω_max is about twice this.

use serde_json::{Value, json};

use crate::elastic::ElasticBody;
use crate::integrator::{IncrementalPotential, SolverParams, StepContext, StepKind};
use crate::linear::System;
use crate::linear::cg::CgParams;
use crate::material::{Definiteness, Material, Model};
use crate::math::{Mat3, Vec3};
use crate::scene::Scene;
use crate::sim::Simulation;

/// Block iterations the frequency estimate may take (three solves each).
pub const MAX_ITERATIONS: usize = 8;

/// The estimate stops when ω² changes by less than this from one block to the next. The
/// convergence is geometric and fast, so the error is then far smaller: on the sample beams the
/// third block changes ω² by 2e-5 and is within 3e-8 of the converged value.
const CONVERGED: f64 = 1e-4;

/// CG's relative tolerance in the estimate's solves: any subspace gives upper bounds, and an
/// error ε in the vectors moves the Ritz value by about ε². 1e-4 gave the same ω² to 1e-9 as
/// 1e-10 on the 192k-tet bench beam.
const SOLVE_TOLERANCE: f64 = 1e-4;

/// How much work the frequency estimate may do.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Effort {
    /// `tetsim info`: blocks until ω² changes by less than 1e-4 (at most [`MAX_ITERATIONS`]),
    /// solves to [`SOLVE_TOLERANCE`].
    #[default]
    Converged,
    /// A run's manifest, at a bounded cost: two blocks (so the last change is known), solves to
    /// 1e-2 (still an upper bound; see docs/performance.md for its cost and accuracy).
    Bounded,
}

impl Effort {
    /// (blocks at most, CG's relative tolerance).
    fn limits(self) -> (usize, f64) {
        match self {
            Effort::Converged => (MAX_ITERATIONS, SOLVE_TOLERANCE),
            Effort::Bounded => (2, 1e-2),
        }
    }
}

/// A material's moduli and wave speeds.
#[derive(Clone, Debug, PartialEq)]
pub struct MaterialInfo {
    /// Where it comes from: `[material]`, `[[body]] name`, `[[volume]] #k`.
    pub name: String,
    /// The model's scene name.
    pub model: String,
    /// Tets of this material.
    pub tets: usize,
    /// Shear modulus μ at rest, Pa.
    pub mu: f64,
    /// Lamé λ at rest, Pa.
    pub lambda: f64,
    /// Density, kg/m³.
    pub density: f64,
}

impl MaterialInfo {
    /// Young's modulus E = μ(3λ + 2μ)/(λ + μ), Pa.
    pub fn youngs_modulus(&self) -> f64 {
        self.mu * (3.0 * self.lambda + 2.0 * self.mu) / (self.lambda + self.mu)
    }

    /// Poisson ratio ν = λ / (2(λ + μ)).
    pub fn poisson_ratio(&self) -> f64 {
        self.lambda / (2.0 * (self.lambda + self.mu))
    }

    /// Pressure-wave speed √((λ + 2μ)/ρ), m/s.
    pub fn p_wave_speed(&self) -> f64 {
        ((self.lambda + 2.0 * self.mu) / self.density).sqrt()
    }

    /// Shear-wave speed √(μ/ρ), m/s.
    pub fn s_wave_speed(&self) -> f64 {
        (self.mu / self.density).sqrt()
    }
}

/// The lowest-frequency estimate (see the module docs).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FrequencyEstimate {
    /// f₁, Hz (0 when rigid); None when it could not be estimated (see `note`).
    pub hz: Option<f64>,
    /// The constraints leave a rigid motion free (nothing fixed, or not enough).
    pub rigid: bool,
    /// Solves done.
    pub iterations: usize,
    /// Relative change of ω² in the last iteration (how far from converged).
    pub last_change: f64,
    /// Why there is no estimate, when there is none.
    pub note: Option<String>,
    /// The work it was allowed.
    pub effort: Effort,
}

/// Everything `tetsim info` reports.
#[derive(Clone, Debug, PartialEq)]
pub struct SceneInfo {
    /// Vertices.
    pub vertices: usize,
    /// Tets.
    pub tets: usize,
    /// Nodes per tet: 4, or 10 for quadratic tets.
    pub nodes_per_tet: usize,
    /// Σ ρW, kg.
    pub mass: f64,
    /// Σ W, m³.
    pub volume: f64,
    /// Rest bounding box (min, max), m.
    pub bounding_box: (Vec3, Vec3),
    /// Constrained components (x, y, z of a vertex count separately).
    pub constrained_components: usize,
    /// Each material used by at least one tet.
    pub materials: Vec<MaterialInfo>,
    /// The lowest natural frequency, estimated.
    pub lowest_frequency: FrequencyEstimate,
    /// The scene's step h = dt/substeps, s (quasistatic: None).
    pub step: Option<f64>,
    /// The scene's time scheme.
    pub integrator: crate::integrator::Integrator,
    /// Smallest tet inradius, m.
    pub min_inradius: f64,
    /// min r/c_p over the tets, s.
    pub explicit_stability_dt: f64,
}

impl SceneInfo {
    /// T₁/20, s (None without a positive frequency).
    pub fn backward_euler_accuracy_dt(&self) -> Option<f64> {
        self.lowest_frequency
            .hz
            .filter(|&f| f > 0.0)
            .map(|f| 1.0 / (20.0 * f))
    }

    /// The share of the lowest mode's amplitude backward Euler takes per period at the scene's
    /// step: `1 − (1 + (ωh)²)^(−π/(ωh))`.
    pub fn backward_euler_damping_per_period(&self) -> Option<f64> {
        let f = self.lowest_frequency.hz.filter(|&f| f > 0.0)?;
        let wh = 2.0 * std::f64::consts::PI * f * self.step?;
        Some(-(-(std::f64::consts::PI / wh) * (wh * wh).ln_1p()).exp_m1())
    }

    /// The share of the lowest mode's amplitude `scheme` keeps per period of it at the scene's
    /// step (a free undamped linear oscillation): the scheme's spectral radius at ωh, raised to
    /// the steps per period 2π/(ωh).
    pub fn amplitude_kept_per_period(&self, scheme: crate::integrator::Integrator) -> Option<f64> {
        let f = self.lowest_frequency.hz.filter(|&f| f > 0.0)?;
        let wh = 2.0 * std::f64::consts::PI * f * self.step?;
        Some(
            scheme
                .amplitude_per_step(wh)
                .powf(2.0 * std::f64::consts::PI / wh),
        )
    }

    /// The `info` object of manifest.json and `tetsim info --json`.
    pub fn to_json(&self) -> Value {
        let (lo, hi) = self.bounding_box;
        let f = &self.lowest_frequency;
        json!({
            "vertices": self.vertices,
            "tets": self.tets,
            "mass": self.mass,
            "volume": self.volume,
            "bounding_box": { "min": [lo[0], lo[1], lo[2]], "max": [hi[0], hi[1], hi[2]] },
            "constrained_components": self.constrained_components,
            "materials": self.materials.iter().map(|m| json!({
                "name": m.name,
                "model": m.model,
                "tets": m.tets,
                "youngs_modulus": m.youngs_modulus(),
                "poisson_ratio": m.poisson_ratio(),
                "mu": m.mu,
                "lambda": m.lambda,
                "density": m.density,
                "p_wave_speed": m.p_wave_speed(),
                "s_wave_speed": m.s_wave_speed(),
            })).collect::<Vec<_>>(),
            "lowest_frequency": {
                "hz": f.hz,
                "estimate": "shifted subspace iteration, 3 vectors, Rayleigh-Ritz (an upper bound)",
                "rigid": f.rigid,
                "iterations": f.iterations,
                "last_change": f.last_change,
                "effort": match f.effort {
                    Effort::Converged => "converged (to 1e-4 in ω²)",
                    Effort::Bounded => "bounded (two blocks, solves to 1e-2)",
                },
                "note": f.note,
            },
            "dt": {
                "scene_step": self.step,
                "backward_euler_accuracy": self.backward_euler_accuracy_dt(),
                "backward_euler_damping_per_period": self.backward_euler_damping_per_period(),
                "integrator": self.integrator.name(),
                "amplitude_kept_per_period": self.amplitude_kept_per_period(self.integrator),
                "explicit_stability": self.explicit_stability_dt,
                "min_inradius": self.min_inradius,
            },
        })
    }
}

/// The small-strain μ and λ of `model` from its tangent at rest.
pub fn rest_moduli(model: &Model) -> (f64, f64) {
    let at = |i: usize, j: usize| {
        let mut df = Mat3::zeros();
        df[(i, j)] = 1.0;
        model.stress_differential(&Mat3::identity(), &df)[(i, j)]
    };
    let (p_modulus, mu) = (at(0, 0), at(0, 1));
    (mu, p_modulus - 2.0 * mu)
}

/// Describe the simulation `sim` made from `scene`.
pub fn describe(scene: &Scene, sim: &Simulation) -> SceneInfo {
    describe_with(scene, sim, Effort::Converged)
}

/// [`describe`] with the frequency estimate's effort given.
pub fn describe_with(scene: &Scene, sim: &Simulation, effort: Effort) -> SceneInfo {
    let body = &sim.body;
    let materials = materials(scene, body);
    let p_speed: Vec<f64> = (0..materials_len(body))
        .map(|k| {
            let (model, density) = body.material(k);
            let (mu, lambda) = rest_moduli(model);
            ((lambda + 2.0 * mu) / density).sqrt()
        })
        .collect();
    let (mut min_inradius, mut explicit) = (f64::INFINITY, f64::INFINITY);
    for t in 0..body.tet_count() {
        let r = inradius(&body.mesh.positions, &body.mesh.tets[t]);
        min_inradius = min_inradius.min(r);
        explicit = explicit.min(r / p_speed[body.material_index(t)]);
    }
    let shear = materials
        .iter()
        .map(MaterialInfo::s_wave_speed)
        .fold(f64::INFINITY, f64::min);
    let (lo, hi) = body.mesh.bounding_box();
    let step = sim
        .params
        .integrator
        .is_dynamic()
        .then(|| sim.params.dt / sim.params.substeps as f64);
    SceneInfo {
        vertices: body.vertex_count(),
        tets: body.tet_count(),
        nodes_per_tet: body.mesh.nodes_per_tet(),
        mass: body.masses().iter().sum(),
        volume: body.volumes().iter().sum(),
        bounding_box: (lo, hi),
        constrained_components: sim.boundary.constrained_dofs(body.vertex_count()),
        lowest_frequency: lowest_frequency(
            body,
            &sim.boundary.free_mask(body.vertex_count()),
            &sim.params,
            shear / (hi - lo).norm(),
            effort,
        ),
        materials,
        step,
        integrator: sim.params.integrator,
        min_inradius,
        explicit_stability_dt: explicit,
    }
}

fn materials_len(body: &ElasticBody) -> usize {
    body.material_counts().len()
}

/// The materials in use, named after the scene table each comes from (regions are the bodies
/// after the first, then the `[[volume]]`s: see `Simulation::from_scene`).
fn materials(scene: &Scene, body: &ElasticBody) -> Vec<MaterialInfo> {
    let counts = body.material_counts();
    let names = crate::scene::body_names(scene);
    counts
        .iter()
        .enumerate()
        .filter(|&(_, &n)| n > 0)
        .map(|(k, &tets)| {
            let name = match k {
                0 => "[material]".to_string(),
                k if k <= scene.body.len() => format!("[[body]] {}", names[k]),
                k => format!("[[volume]] #{}", k - scene.body.len()),
            };
            let (model, density) = body.material(k);
            let (mu, lambda) = rest_moduli(model);
            MaterialInfo {
                name,
                model: model.kind().name().to_string(),
                tets,
                mu,
                lambda,
                density,
            }
        })
        .collect()
}

/// 3V over the surface area of the tet.
fn inradius(x: &[Vec3], tet: &[usize; 4]) -> f64 {
    let p = tet.map(|v| x[v]);
    let volume = (p[1] - p[0])
        .cross(&(p[2] - p[0]))
        .dot(&(p[3] - p[0]))
        .abs()
        / 6.0;
    let area = |a: usize, b: usize, c: usize| 0.5 * (p[b] - p[a]).cross(&(p[c] - p[a])).norm();
    let surface = area(1, 2, 3) + area(0, 2, 3) + area(0, 1, 3) + area(0, 1, 2);
    3.0 * volume / surface
}

/// A reproducible disturbance in [−1, 1]³ for vertex i (xorshift on the index).
fn disturbance(i: usize) -> Vec3 {
    let mut s = (i as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
    let mut next = || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        (s >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    };
    Vec3::new(next(), next(), next())
}

/// The estimate of the module docs; `rate` = c_s/L, 1/s, sets the shift.
fn lowest_frequency(
    body: &ElasticBody,
    free: &[Vec3],
    scene_params: &SolverParams,
    rate: f64,
    effort: Effort,
) -> FrequencyEstimate {
    let (max_iterations, solve_tolerance) = effort.limits();
    let n = body.vertex_count();
    if free.iter().all(|m| *m == Vec3::repeat(1.0)) {
        return FrequencyEstimate {
            hz: Some(0.0),
            rigid: true,
            note: Some("nothing is fixed: the body moves rigidly".into()),
            ..Default::default()
        };
    }
    let sigma = 1e-5 * rate * rate;
    if !(sigma > 0.0 && sigma.is_finite()) {
        return FrequencyEstimate {
            note: Some("no finite wave speed and size to scale the shift by".into()),
            ..Default::default()
        };
    }
    // (K + σM) is the backward-Euler system of a step h = 1/√σ without damping, at rest.
    let params = SolverParams {
        integrator: crate::integrator::Integrator::BackwardEuler,
        rayleigh_stiffness: 0.0,
        rayleigh_mass: 0.0,
        definiteness: Definiteness::Projected,
        // The shift is small: K + σM is nearly singular, beyond what an f32 A resolves.
        matrix_precision: crate::integrator::MatrixPrecision::F64,
        ..scene_params.clone()
    };
    let rest = &body.mesh.positions;
    let zeros = vec![Vec3::zeros(); n];
    let step = crate::integrator::BackwardEulerStep::new(rest, &zeros, 1.0 / sigma.sqrt());
    let ctx = StepContext {
        body,
        kind: StepKind::Dynamic(step.inertial()),
        f_ext: &zeros,
        free,
        params: &params,
    };
    let mut potential = IncrementalPotential::new(body, &params);
    let mut scratch = vec![Vec3::zeros(); n];
    let mut partials = vec![0.0; n.div_ceil(2048).max(1)];
    potential.evaluate(&ctx, rest, &zeros, &mut scratch, &mut partials);
    let mut problem = crate::integrator::problem::Problem::new(&mut potential, &ctx);
    let mut solver = crate::linear::make_solver(&params.linear(), n);
    solver.prepare(&mut problem, free);
    let masses = body.masses();
    let cg = CgParams {
        tolerance: solve_tolerance,
        max_iterations: scene_params.cg.max_iterations,
    };
    // Start: uniform body forces along x, y and z, each disturbed its own way.
    let mut block: Vec<Vec<Vec3>> = (0..BLOCK)
        .map(|c| {
            (0..n)
                .map(|i| {
                    let mut d = 0.1 * disturbance(i * BLOCK + c);
                    d[c] += 1.0;
                    d.component_mul(&free[i])
                })
                .collect()
        })
        .collect();
    let mut estimate = FrequencyEstimate {
        effort,
        ..Default::default()
    };
    let mut omega2 = f64::NAN;
    let mut b = vec![Vec3::zeros(); n];
    for k in 1..=max_iterations {
        // W = (K + σM)⁻¹·M·U, one solve per column.
        let mut w = Vec::with_capacity(block.len());
        for u in &block {
            for i in 0..n {
                b[i] = masses[i] * u[i];
            }
            let mut x = vec![Vec3::zeros(); n];
            match solver.solve(&mut problem, &b, &mut x, free, &cg) {
                Ok(info) if !info.converged => {
                    estimate.note = Some(format!(
                        "a solve stopped at CG's cap with relative residual {:.1e}",
                        info.relative_residual
                    ));
                }
                Ok(_) => {}
                Err(e) => {
                    estimate.note = Some(format!("the linear solve failed: {e}"));
                    return estimate;
                }
            }
            w.push(x);
        }
        // Rayleigh-Ritz on span(W): M-orthonormal columns, then the eigenvectors of WᵀKW.
        let w = m_orthonormal(w, masses);
        if w.is_empty() {
            estimate.note = Some("the iteration lost its vectors (no free vertex moves)".into());
            return estimate;
        }
        let kw: Vec<Vec<Vec3>> = w
            .iter()
            .map(|x| {
                let mut ax = vec![Vec3::zeros(); n];
                problem.apply(x, &mut ax);
                (0..n)
                    .map(|i| ax[i].component_mul(&free[i]) - sigma * masses[i] * x[i])
                    .collect()
            })
            .collect();
        let size = w.len();
        let reduced = nalgebra::DMatrix::from_fn(size, size, |a, c| {
            let ab = dot(&w[a], &kw[c]);
            let ba = dot(&w[c], &kw[a]);
            0.5 * (ab + ba)
        });
        let eigen = reduced.symmetric_eigen();
        let mut order: Vec<usize> = (0..size).collect();
        order.sort_by(|&a, &c| eigen.eigenvalues[a].total_cmp(&eigen.eigenvalues[c]));
        block = order
            .iter()
            .map(|&j| {
                (0..n)
                    .map(|i| {
                        (0..size).fold(Vec3::zeros(), |sum, a| {
                            sum + eigen.eigenvectors[(a, j)] * w[a][i]
                        })
                    })
                    .collect()
            })
            .collect();
        let previous = omega2;
        omega2 = eigen.eigenvalues[order[0]].max(0.0);
        estimate.iterations = k;
        estimate.last_change = if omega2 > 0.0 {
            ((omega2 - previous) / omega2).abs()
        } else {
            0.0
        };
        if estimate.last_change < CONVERGED {
            break;
        }
    }
    if omega2 < 1e-2 * sigma {
        estimate.rigid = true;
        estimate.hz = Some(0.0);
        estimate.note = Some("the constraints leave a rigid motion free".into());
    } else {
        estimate.hz = Some(omega2.sqrt() / (2.0 * std::f64::consts::PI));
    }
    estimate
}

/// Vectors in the block of the subspace iteration: the lowest modes of a beam are two bendings
/// and a twist or a stretch, so three vectors separate the lowest from the fourth.
const BLOCK: usize = 3;

fn dot(a: &[Vec3], b: &[Vec3]) -> f64 {
    a.iter().zip(b).map(|(a, b)| a.dot(b)).sum()
}

/// Modified Gram-Schmidt in the M inner product; columns that vanish are dropped.
fn m_orthonormal(mut w: Vec<Vec<Vec3>>, masses: &[f64]) -> Vec<Vec<Vec3>> {
    let m_dot = |a: &[Vec3], b: &[Vec3]| -> f64 {
        a.iter()
            .zip(b)
            .zip(masses)
            .map(|((a, b), m)| m * a.dot(b))
            .sum()
    };
    let mut kept: Vec<Vec<Vec3>> = Vec::with_capacity(w.len());
    for mut x in w.drain(..) {
        let before = m_dot(&x, &x).sqrt();
        for q in &kept {
            let c = m_dot(q, &x);
            x.iter_mut().zip(q).for_each(|(x, q)| *x -= c * q);
        }
        let norm = m_dot(&x, &x).sqrt();
        if norm > 1e-8 * before && norm.is_finite() {
            x.iter_mut().for_each(|x| *x /= norm);
            kept.push(x);
        }
    }
    kept
}

/// `tetsim info`'s text: the numbers with their units.
pub fn report(info: &SceneInfo, sim: &Simulation) -> String {
    use std::fmt::Write as _;
    let mut s = String::new();
    let (lo, hi) = info.bounding_box;
    let kind = if info.nodes_per_tet == 10 {
        " (quadratic, 10 nodes each)"
    } else {
        ""
    };
    let _ = writeln!(
        s,
        "mesh: {} vertices, {} tets{kind}",
        info.vertices, info.tets
    );
    let _ = writeln!(
        s,
        "bounding box: [{}, {}, {}] .. [{}, {}, {}] m",
        num(lo[0]),
        num(lo[1]),
        num(lo[2]),
        num(hi[0]),
        num(hi[1]),
        num(hi[2])
    );
    let _ = writeln!(s, "volume: {} m³", num(info.volume));
    let _ = writeln!(s, "mass: {} kg", num(info.mass));
    let _ = writeln!(s, "constrained components: {}", info.constrained_components);
    for m in &info.materials {
        let _ = writeln!(
            s,
            "{} ({}, {} tets): E = {} Pa, ν = {}, μ = {} Pa, λ = {} Pa, ρ = {} kg/m³; \
             wave speeds: P {} m/s, S {} m/s",
            m.name,
            m.model,
            m.tets,
            num(m.youngs_modulus()),
            num(m.poisson_ratio()),
            num(m.mu),
            num(m.lambda),
            num(m.density),
            num(m.p_wave_speed()),
            num(m.s_wave_speed())
        );
    }
    let f = &info.lowest_frequency;
    match (f.hz, f.rigid) {
        (Some(_), true) => {
            let _ = writeln!(
                s,
                "lowest frequency: 0 Hz ({})",
                f.note.as_deref().unwrap_or("rigid")
            );
        }
        (Some(hz), false) => {
            let _ = writeln!(
                s,
                "lowest frequency (estimate, an upper bound): {} Hz, period {} s \
                 ({} subspace iterations, last change {:.1e})",
                num(hz),
                num(1.0 / hz),
                f.iterations,
                f.last_change
            );
        }
        (None, _) => {
            let _ = writeln!(
                s,
                "lowest frequency: not estimated ({})",
                f.note.as_deref().unwrap_or("unknown")
            );
        }
    }
    let p = &sim.params;
    match info.step {
        Some(h) => {
            let _ = writeln!(
                s,
                "time step: dt = {} s, {} substep(s): h = {} s; {} frames, {} s in all",
                num(p.dt),
                p.substeps,
                num(h),
                p.frames,
                num(p.dt * p.frames as f64)
            );
        }
        None => {
            let _ = writeln!(s, "quasistatic: {} load steps", p.frames);
        }
    }
    if let Some(dt) = info.backward_euler_accuracy_dt() {
        let _ = writeln!(
            s,
            "suggested dt for backward Euler accuracy (T₁/20): {} s",
            num(dt)
        );
    }
    if let Some(loss) = info.backward_euler_damping_per_period() {
        let _ = writeln!(
            s,
            "backward Euler's numerical damping of the lowest mode at h: {:.3} % of its amplitude per period",
            100.0 * loss
        );
    }
    if info.step.is_some() {
        use crate::integrator::Integrator;
        let kept = |scheme| {
            info.amplitude_kept_per_period(scheme)
                .map_or("-".to_string(), |k| format!("{:.3} %", 100.0 * k))
        };
        if info.amplitude_kept_per_period(p.integrator).is_some() {
            let _ = writeln!(
                s,
                "integrator: {}; the lowest mode keeps {} of its amplitude per period at h \
                 (backward-euler {}, bdf2 {}, newmark {})",
                p.integrator.name(),
                kept(p.integrator),
                kept(Integrator::BackwardEuler),
                kept(Integrator::Bdf2),
                kept(Integrator::newmark()),
            );
        } else {
            let _ = writeln!(
                s,
                "integrator: {} (no elastic mode to measure its damping by)",
                p.integrator.name()
            );
        }
    }
    let _ = writeln!(
        s,
        "explicit stability limit (min inradius / P-wave speed; not needed by backward Euler): {} s \
         (min inradius {} m)",
        num(info.explicit_stability_dt),
        num(info.min_inradius)
    );
    let _ = writeln!(
        s,
        "damping: rayleigh_stiffness γ = {} s, rayleigh_mass α = {} 1/s; gravity [{}, {}, {}] m/s²",
        num(p.rayleigh_stiffness),
        num(p.rayleigh_mass),
        num(sim.boundary.gravity[0]),
        num(sim.boundary.gravity[1]),
        num(sim.boundary.gravity[2])
    );
    s
}

/// A number as people write it, to six significant digits: `8`, `0.008`, `10.351`, `36.69`,
/// and `1.5e-9` or `2.1e11` beyond 1e-3 .. 1e6, trailing zeros dropped.
pub fn num(x: f64) -> String {
    if x == 0.0 || !x.is_finite() {
        return format!("{x}");
    }
    let a = x.abs();
    if (1e-3..1e6).contains(&a) {
        let decimals = (5 - a.log10().floor() as i32).max(0) as usize;
        let text = format!("{x:.decimals$}");
        if text.contains('.') {
            text.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            text
        }
    } else {
        let text = format!("{x:.5e}");
        let (mantissa, exponent) = text.split_once('e').unwrap_or((&text, "0"));
        let mantissa = mantissa.trim_end_matches('0').trim_end_matches('.');
        format!("{mantissa}e{exponent}")
    }
}

#[cfg(test)]
mod tests;
