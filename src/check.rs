//! Self-check of a material and a body: every derivative against central finite differences of
//! the function it differentiates, with a sweep of step sizes (the best step counts, HOBAK's
//! habit), and the matrix-free stiffness product against the assembled sparse K.
//!
//! - material level, generic over [`Material`]: Ψ → P (`P:dF` against the difference quotient
//!   of Ψ along dF) and P → dP (`(∂P/∂F):dF` against the difference quotient of P), at random,
//!   near-inverted and inverted F and at the F of a given state;
//! - body level, generic over [`Discretization`]: E → f (`−f·u` against the quotient of E along
//!   u), f → K·u (against the quotient of −f), and K·u matrix-free against the assembled matrix,
//!   at any list of states.
//!
//! - step level, [`check_terms`]: every term of the incremental potential (inertia, elasticity,
//!   loads, and whatever joins them) alone: Φ_term → f_term, f_term → H_term·u, and a block
//!   term's product against its assembly.
//!
//! `tetsim check [SCENE]` runs all three on a scene's material, body and step; the tests run it on every
//! model and on a deliberately wrong one, which must fail.

use std::fmt;

use crate::elastic::{AssemblyWork, ElasticBody};
use crate::integrator::{HessianShape, IncrementalPotential, SolverParams, StepContext, StepKind};
use crate::linear::sparse::BlockCsr;
use crate::material::{Definiteness, Material};
use crate::math::{Mat3, Vec3, svd_rv};

/// Step sizes of the sweep, relative to the scale of the argument (‖F‖ ~ 1, the mean edge length
/// for positions). Central differences reach their best near 1e-5 (truncation against rounding).
pub const STEPS: [f64; 7] = [1e-2, 1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8];

/// Settings of a check run.
#[derive(Clone, Debug, PartialEq)]
pub struct CheckParams {
    /// Largest relative error a finite-difference check may show at its best step. Default 1e-6:
    /// a correct derivative reaches 1e-8 to 1e-10 here; a wrong one (a missing term, a factor
    /// 1.01) is off by 1e-3 or more.
    pub fd_tolerance: f64,
    /// Largest relative difference between the matrix-free and the assembled K·u (no finite
    /// differences: only rounding). Default 1e-9.
    pub assembly_tolerance: f64,
    /// Random F per family for the material checks. Default 8.
    pub samples: usize,
    /// Random directions per state for the body checks. Default 3.
    pub directions: usize,
    /// Seed of the random F and directions (the check is reproducible). Default 1.
    pub seed: u64,
}

impl Default for CheckParams {
    fn default() -> Self {
        CheckParams {
            fd_tolerance: 1e-6,
            assembly_tolerance: 1e-9,
            samples: 8,
            directions: 3,
            seed: 1,
        }
    }
}

/// One line of the report: the worst case of one check over one family of inputs.
#[derive(Clone, Debug, PartialEq)]
pub struct CheckRow {
    /// What is checked, e.g. "Ψ → P".
    pub check: &'static str,
    /// Where, e.g. "random F" or "scene state".
    pub state: String,
    /// How many inputs were checked.
    pub cases: usize,
    /// Inputs skipped (F at the rotation-variant SVD's kink σ₂ = −σ₃, where Ψ is not
    /// differentiable).
    pub skipped: usize,
    /// Largest relative error over the inputs (each at its best step).
    pub relative_error: f64,
    /// The best step of the worst input (0 for checks without finite differences).
    pub step: f64,
    /// The tolerance it is held to.
    pub tolerance: f64,
}

impl CheckRow {
    /// Whether the worst error is within tolerance (and finite).
    pub fn passed(&self) -> bool {
        self.relative_error <= self.tolerance
    }
}

/// Every row of a check run.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CheckReport {
    /// The rows, in the order they were run.
    pub rows: Vec<CheckRow>,
}

impl CheckReport {
    /// True when every row passed.
    pub fn passed(&self) -> bool {
        self.rows.iter().all(CheckRow::passed)
    }

    /// The rows that failed.
    pub fn failures(&self) -> impl Iterator<Item = &CheckRow> {
        self.rows.iter().filter(|r| !r.passed())
    }
}

impl fmt::Display for CheckReport {
    /// A fixed-width table, one row per check and state, then PASS or FAIL.
    fn fmt(&self, out: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            out,
            "{:<24} {:<30} {:>6} {:>12} {:>8} {:>9}  result",
            "check", "state", "cases", "rel. error", "step", "tolerance"
        )?;
        for r in &self.rows {
            let state = if r.skipped > 0 {
                format!("{} ({} at SVD kink skipped)", r.state, r.skipped)
            } else {
                r.state.clone()
            };
            writeln!(
                out,
                "{:<24} {:<30} {:>6} {:>12.2e} {:>8.0e} {:>9.0e}  {}",
                r.check,
                state,
                r.cases,
                r.relative_error,
                r.step,
                r.tolerance,
                if r.passed() { "pass" } else { "FAIL" }
            )?;
        }
        let failed = self.failures().count();
        if failed == 0 {
            write!(out, "PASS: all {} checks", self.rows.len())
        } else {
            write!(
                out,
                "FAIL: {failed} of {} checks exceed their tolerance: a derivative does not match \
                 the function it differentiates",
                self.rows.len()
            )
        }
    }
}

/// A small deterministic generator (SplitMix64), so the library needs no RNG crate.
#[derive(Clone, Debug)]
pub struct SplitMix(u64);

impl SplitMix {
    /// Seeded.
    pub fn new(seed: u64) -> Self {
        SplitMix(seed)
    }

    /// Uniform in [0, 1).
    pub fn next_f64(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        (z >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Uniform in [lo, hi).
    pub fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.next_f64()
    }

    /// A vector with entries uniform in [−1, 1).
    pub fn vector(&mut self) -> Vec3 {
        Vec3::new(
            self.uniform(-1.0, 1.0),
            self.uniform(-1.0, 1.0),
            self.uniform(-1.0, 1.0),
        )
    }

    /// A matrix with entries uniform in [−1, 1).
    pub fn matrix(&mut self) -> Mat3 {
        Mat3::from_fn(|_, _| self.uniform(-1.0, 1.0))
    }

    /// A uniformly random rotation (from a normalised Gaussian-free quaternion by rejection).
    pub fn rotation(&mut self) -> Mat3 {
        loop {
            let q = nalgebra::Vector4::new(
                self.uniform(-1.0, 1.0),
                self.uniform(-1.0, 1.0),
                self.uniform(-1.0, 1.0),
                self.uniform(-1.0, 1.0),
            );
            let n = q.norm();
            if n > 1e-3 && n <= 1.0 {
                let q = nalgebra::UnitQuaternion::from_quaternion(nalgebra::Quaternion::from(q));
                return q.to_rotation_matrix().into_inner();
            }
        }
    }
}

/// Families of F for the material checks.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FFamily {
    /// Stretches in [0.5, 2], random rotations.
    Random,
    /// det F = 1e-3.
    NearInverted,
    /// det F < 0 (the smallest stretch negative, up to 60 % of the next).
    Inverted,
}

impl FFamily {
    /// Every family.
    pub const ALL: [FFamily; 3] = [FFamily::Random, FFamily::NearInverted, FFamily::Inverted];

    /// Its name in the report.
    pub fn name(self) -> &'static str {
        match self {
            FFamily::Random => "random F",
            FFamily::NearInverted => "near-inverted F (J=1e-3)",
            FFamily::Inverted => "inverted F (J<0)",
        }
    }

    /// A random F of this family.
    pub fn sample(self, rng: &mut SplitMix) -> Mat3 {
        let s1 = rng.uniform(0.5, 2.0);
        let s2 = rng.uniform(0.5, 1.6);
        let s3 = match self {
            FFamily::Random => rng.uniform(0.5, 1.5),
            FFamily::NearInverted => 1e-3 / (s1 * s2),
            FFamily::Inverted => -rng.uniform(0.05, 0.6) * s1.min(s2),
        };
        rng.rotation() * Mat3::from_diagonal(&Vec3::new(s1, s2, s3)) * rng.rotation()
    }
}

/// True when F is within a relative 1e-3 of the rotation-variant SVD's kink σ₂ = −σ₃ (all of a
/// collapsed-to-a-point F is): Ψ has no derivative there, so no check applies.
pub fn at_svd_kink(f: &Mat3) -> bool {
    let s = svd_rv(f).sigma;
    s[1] + s[2] <= 1e-3 * s[0].abs().max(1e-300)
}

/// The best relative error of `analytic` against the central differences `fd(h)` over the step
/// sweep (each h scaled by `scale`), relative to the largest of the two norms and `floor`.
pub fn best_relative_error(
    analytic: &[f64],
    scale: f64,
    floor: f64,
    mut fd: impl FnMut(f64) -> Vec<f64>,
) -> (f64, f64) {
    let norm = |v: &[f64]| v.iter().map(|x| x * x).sum::<f64>().sqrt();
    STEPS
        .iter()
        .map(|&step| {
            let approx = fd(step * scale);
            let diff: Vec<f64> = approx.iter().zip(analytic).map(|(a, b)| a - b).collect();
            let denominator = norm(analytic).max(norm(&approx)).max(floor);
            let error = norm(&diff) / denominator;
            (if error.is_nan() { f64::INFINITY } else { error }, step)
        })
        .min_by(|a, b| a.0.total_cmp(&b.0))
        .unwrap_or((f64::INFINITY, 0.0))
}

/// A stress scale of a material: |∂P₁₁/∂F₁₁| at rest (λ + 2μ for isotropic models), the floor
/// of relative errors for stresses that are nearly zero.
pub fn stress_scale<M: Material>(material: &M) -> f64 {
    let mut df = Mat3::zeros();
    df[(0, 0)] = 1.0;
    material
        .stress_differential(&Mat3::identity(), &df)
        .norm()
        .max(f64::MIN_POSITIVE)
}

/// Ψ → P and P → dP on the given deformation gradients (one row per check), skipping any F at
/// the SVD kink. `label` names the set in the report.
pub fn check_material_at<M: Material>(
    material: &M,
    label: &str,
    fs: &[Mat3],
    params: &CheckParams,
    rng: &mut SplitMix,
) -> Vec<CheckRow> {
    // At rest P = 0 and the quotient of Ψ is all rounding (Ψ ~ μ·3 cancels to ~h²): errors are
    // relative to at least the stress of a 0.01 % strain.
    let floor = 1e-4 * stress_scale(material);
    let mut psi_row = CheckRow {
        check: "Ψ → P",
        state: label.to_string(),
        cases: 0,
        skipped: 0,
        relative_error: 0.0,
        step: 0.0,
        tolerance: params.fd_tolerance,
    };
    let mut dp_row = CheckRow {
        check: "P → dP",
        ..psi_row.clone()
    };
    for f in fs {
        if at_svd_kink(f) {
            psi_row.skipped += 1;
            dp_row.skipped += 1;
            continue;
        }
        let df = rng.matrix();
        let scale = f.norm().max(1e-3);
        let analytic = [material.stress(f).dot(&df)];
        let (e, h) = best_relative_error(&analytic, scale, floor, |h| {
            vec![
                (material.energy_density(&(f + h * df)) - material.energy_density(&(f - h * df)))
                    / (2.0 * h),
            ]
        });
        worst(&mut psi_row, e, h);
        let analytic: Vec<f64> = material
            .stress_differential(f, &df)
            .iter()
            .copied()
            .collect();
        let (e, h) = best_relative_error(&analytic, scale, floor, |h| {
            ((material.stress(&(f + h * df)) - material.stress(&(f - h * df))) / (2.0 * h))
                .iter()
                .copied()
                .collect()
        });
        worst(&mut dp_row, e, h);
        // The tangent the solver applies must be the same operator.
        let tangent = material.tangent(f, Definiteness::Exact).apply(&df);
        let gap =
            (tangent - material.stress_differential(f, &df)).norm() / (tangent.norm().max(floor));
        worst(&mut dp_row, gap, 0.0);
        psi_row.cases += 1;
        dp_row.cases += 1;
    }
    vec![psi_row, dp_row]
}

/// Ψ → P and P → dP on `params.samples` random F of every [`FFamily`].
pub fn check_material<M: Material>(material: &M, params: &CheckParams) -> Vec<CheckRow> {
    let mut rng = SplitMix::new(params.seed);
    let mut rows = Vec::new();
    for family in FFamily::ALL {
        let fs: Vec<Mat3> = (0..params.samples)
            .map(|_| family.sample(&mut rng))
            .collect();
        rows.extend(check_material_at(
            material,
            family.name(),
            &fs,
            params,
            &mut rng,
        ));
    }
    rows
}

/// Keep the larger error (NaN counts as infinite) and its step.
fn worst(row: &mut CheckRow, error: f64, step: f64) {
    let error = if error.is_nan() { f64::INFINITY } else { error };
    if error > row.relative_error {
        row.relative_error = error;
        if step != 0.0 {
            row.step = step;
        }
    }
}

/// What the body-level checks need: an energy, its forces, and the stiffness product two ways.
/// [`ElasticBody`] implements it; tests implement it for deliberately wrong bodies.
pub trait Discretization {
    /// Number of vertices.
    fn vertex_count(&self) -> usize;
    /// A length scale for finite-difference steps (the mean edge length), m.
    fn length_scale(&self) -> f64;
    /// A force scale for relative errors of nearly-zero forces, N.
    fn force_scale(&self) -> f64;
    /// E(x), J.
    fn energy(&self, x: &[Vec3]) -> f64;
    /// `out = f(x) = −∂E/∂x` (overwrite), N.
    fn forces(&self, x: &[Vec3], out: &mut [Vec3]);
    /// `out = K(x)·u` matrix-free, with the exact (unprojected) tangent when `definiteness` is
    /// Exact.
    fn stiffness_product(&self, x: &[Vec3], u: &[Vec3], d: Definiteness, out: &mut [Vec3]);
    /// `out = K(x)·u` through the assembled sparse matrix.
    fn assembled_product(&self, x: &[Vec3], u: &[Vec3], d: Definiteness, out: &mut [Vec3]);
}

impl Discretization for ElasticBody {
    fn vertex_count(&self) -> usize {
        ElasticBody::vertex_count(self)
    }

    fn length_scale(&self) -> f64 {
        self.mesh.mean_edge_length()
    }

    fn force_scale(&self) -> f64 {
        let edge = self.mesh.mean_edge_length();
        stress_scale(&self.model) * edge * edge
    }

    fn energy(&self, x: &[Vec3]) -> f64 {
        ElasticBody::energy(self, x)
    }

    fn forces(&self, x: &[Vec3], out: &mut [Vec3]) {
        out.iter_mut().for_each(|f| *f = Vec3::zeros());
        self.add_forces(x, out);
    }

    fn stiffness_product(&self, x: &[Vec3], u: &[Vec3], d: Definiteness, out: &mut [Vec3]) {
        let mut lin = self.linearize(x, d);
        self.apply_stiffness(&mut lin, u, out);
    }

    fn assembled_product(&self, x: &[Vec3], u: &[Vec3], d: Definiteness, out: &mut [Vec3]) {
        let lin = self.linearize(x, d);
        let mut a = BlockCsr::zeros(self.stiffness_pattern());
        self.assemble_system(&lin, 1.0, 0.0, &mut a, &mut AssemblyWork::default());
        a.multiply(u, out);
    }
}

fn axpy(x: &[Vec3], t: f64, u: &[Vec3]) -> Vec<Vec3> {
    x.iter().zip(u).map(|(x, u)| x + t * u).collect()
}

fn flatten(v: &[Vec3]) -> Vec<f64> {
    v.iter().flat_map(|p| p.iter().copied()).collect()
}

/// E → f, f → K·u (exact tangent) and matrix-free against assembled K·u (exact and projected)
/// at each labelled state, with `params.directions` random directions u each.
pub fn check_body<D: Discretization>(
    body: &D,
    states: &[(String, Vec<Vec3>)],
    params: &CheckParams,
) -> Vec<CheckRow> {
    let mut rng = SplitMix::new(params.seed.wrapping_add(17));
    let n = body.vertex_count();
    let (edge, force_floor) = (body.length_scale(), 1e-6 * body.force_scale());
    let mut rows = Vec::new();
    for (label, x) in states {
        let row = |check: &'static str, tolerance: f64| CheckRow {
            check,
            state: label.clone(),
            cases: 0,
            skipped: 0,
            relative_error: 0.0,
            step: 0.0,
            tolerance,
        };
        let mut energy_row = row("E → f", params.fd_tolerance);
        let mut force_row = row("f → K·u", params.fd_tolerance);
        let mut assembled_row = row("K·u vs assembled K", params.assembly_tolerance);
        let mut f = vec![Vec3::zeros(); n];
        body.forces(x, &mut f);
        let (mut fp, mut fm) = (vec![Vec3::zeros(); n], vec![Vec3::zeros(); n]);
        for _ in 0..params.directions {
            let u: Vec<Vec3> = (0..n).map(|_| rng.vector()).collect();
            let u_norm = flatten(&u).iter().map(|c| c * c).sum::<f64>().sqrt();
            let analytic = [-f.iter().zip(&u).map(|(f, u)| f.dot(u)).sum::<f64>()];
            let (e, h) = best_relative_error(&analytic, edge, force_floor * u_norm, |h| {
                vec![(body.energy(&axpy(x, h, &u)) - body.energy(&axpy(x, -h, &u))) / (2.0 * h)]
            });
            worst(&mut energy_row, e, h);
            let mut ku = vec![Vec3::zeros(); n];
            body.stiffness_product(x, &u, Definiteness::Exact, &mut ku);
            let analytic = flatten(&ku);
            let (e, h) = best_relative_error(&analytic, edge, force_floor / edge, |h| {
                body.forces(&axpy(x, h, &u), &mut fp);
                body.forces(&axpy(x, -h, &u), &mut fm);
                // K·u = −df/dx·u
                fp.iter()
                    .zip(&fm)
                    .flat_map(|(p, m)| ((m - p) / (2.0 * h)).iter().copied().collect::<Vec<_>>())
                    .collect()
            });
            worst(&mut force_row, e, h);
            energy_row.cases += 1;
            force_row.cases += 1;
            for d in [Definiteness::Exact, Definiteness::Projected] {
                let mut matrix_free = vec![Vec3::zeros(); n];
                let mut assembled = vec![Vec3::zeros(); n];
                body.stiffness_product(x, &u, d, &mut matrix_free);
                body.assembled_product(x, &u, d, &mut assembled);
                let a = flatten(&matrix_free);
                let b = flatten(&assembled);
                let norm = |v: &[f64]| v.iter().map(|c| c * c).sum::<f64>().sqrt();
                let diff: Vec<f64> = a.iter().zip(&b).map(|(a, b)| a - b).collect();
                let e = norm(&diff) / norm(&a).max(norm(&b)).max(force_floor / edge);
                worst(&mut assembled_row, e, 0.0);
                assembled_row.cases += 1;
            }
        }
        rows.extend([energy_row, force_row, assembled_row]);
    }
    rows
}

/// The states `tetsim check` uses for a body whose run starts at `initial`: the initial state,
/// rest plus a random displacement of 20 % of an edge, and every tet inverted (rest with z
/// scaled by −0.3). Each is nudged by a random 0.1 % of an edge, so that no tet sits exactly on
/// the SVD kink (a collapsed start puts all of them there) and forces are not exactly zero.
pub fn body_states(body: &ElasticBody, initial: &[Vec3], seed: u64) -> Vec<(String, Vec<Vec3>)> {
    let mut rng = SplitMix::new(seed.wrapping_add(31));
    let edge = body.mesh.mean_edge_length();
    let rest = &body.mesh.positions;
    let mut nudge = |x: Vec<Vec3>, amount: f64| -> Vec<Vec3> {
        x.into_iter()
            .map(|p| p + amount * edge * rng.vector())
            .collect()
    };
    let initial = nudge(initial.to_vec(), 1e-3);
    let deformed = nudge(rest.clone(), 0.2);
    let (lo, hi) = crate::mesh::bounding_box(rest);
    let mid = 0.5 * (lo.z + hi.z);
    let inverted = nudge(
        rest.iter()
            .map(|p| Vec3::new(p.x, p.y, mid - 0.3 * (p.z - mid)))
            .collect(),
        1e-3,
    );
    vec![
        ("initial state".to_string(), initial),
        ("rest + 0.2 edge random".to_string(), deformed),
        ("every tet inverted".to_string(), inverted),
    ]
}

/// The F of up to `count` tets of `body` at `x`: the smallest J first, then evenly spread.
pub fn state_gradients(body: &ElasticBody, x: &[Vec3], count: usize) -> Vec<Mat3> {
    let j = body.jacobians(x);
    let mut order: Vec<usize> = (0..j.len()).collect();
    order.sort_by(|a, b| j[*a].total_cmp(&j[*b]).then(a.cmp(b)));
    let mut picked: Vec<usize> = order.iter().take(count / 2).copied().collect();
    let stride = (j.len() / (count - count / 2).max(1)).max(1);
    picked.extend((0..j.len()).step_by(stride).take(count - count / 2));
    picked.sort_unstable();
    picked.dedup();
    picked
        .into_iter()
        .map(|t| body.deformation_gradient(x, t))
        .collect()
}

/// The whole `tetsim check`: the material at random, near-inverted and inverted F and at the F
/// of the initial state, and the body at [`body_states`].
pub fn check_simulation(body: &ElasticBody, initial: &[Vec3], params: &CheckParams) -> CheckReport {
    let mut rows = check_material(&body.model, params);
    let mut rng = SplitMix::new(params.seed.wrapping_add(7));
    let fs = state_gradients(body, initial, 2 * params.samples);
    rows.extend(check_material_at(
        &body.model,
        "F of the initial state",
        &fs,
        params,
        &mut rng,
    ));
    rows.extend(check_body(
        body,
        &body_states(body, initial, params.seed),
        params,
    ));
    CheckReport { rows }
}

/// Every term of the incremental potential of a backward-Euler step of `dt` from `initial`
/// (with a random velocity, gravity and the scene's settings, damping left out: its force has
/// no potential): energy → force, force → Hessian·u (the exact Hessian), and for block terms the
/// Hessian product against the assembled Hessian, each at [`body_states`]. Linear terms
/// (loads) must show a zero force differential.
pub fn check_terms(
    body: &ElasticBody,
    initial: &[Vec3],
    solver: &SolverParams,
    gravity: Vec3,
    params: &CheckParams,
) -> Vec<CheckRow> {
    let n = body.vertex_count();
    let mut rng = SplitMix::new(params.seed.wrapping_add(53));
    let edge = body.mesh.mean_edge_length();
    let h = solver.dt;
    let mut solver = solver.clone();
    solver.rayleigh_stiffness = 0.0;
    solver.definiteness = Definiteness::Exact;
    let xn = initial.to_vec();
    let vn: Vec<Vec3> = (0..n).map(|_| 0.1 * edge / h * rng.vector()).collect();
    let f_ext: Vec<Vec3> = body.masses().iter().map(|&m| m * gravity).collect();
    let free = vec![Vec3::repeat(1.0); n];
    let step = crate::integrator::BackwardEulerStep::new(&xn, &vn, h);
    let ctx = StepContext {
        body,
        kind: StepKind::Dynamic(step.inertial()),
        f_ext: &f_ext,
        free: &free,
        params: &solver,
    };
    let mut potential = IncrementalPotential::new(body, &solver);
    let names = potential.term_names();
    let force_floor = 1e-6 * body.force_scale();
    let mut partials = vec![0.0; n.div_ceil(1024).max(1)];
    let mut rows = Vec::new();
    for (label, x) in body_states(body, initial, params.seed) {
        for (k, name) in names.iter().enumerate() {
            let row = |check: &'static str, tolerance: f64| CheckRow {
                check,
                state: format!("{name}, {label}"),
                cases: 0,
                skipped: 0,
                relative_error: 0.0,
                step: 0.0,
                tolerance,
            };
            let mut energy_row = row("term Φ → f", params.fd_tolerance);
            let mut force_row = row("term f → H·u", params.fd_tolerance);
            let mut assembled_row = row("term H·u vs assembled", params.assembly_tolerance);
            // Energy and force of term k alone at y.
            let mut eval =
                |potential: &mut IncrementalPotential, y: &[Vec3], force: &mut [Vec3]| {
                    let v: Vec<Vec3> = y.iter().zip(&xn).map(|(y, xn)| (y - xn) / h).collect();
                    force.iter_mut().for_each(|f| *f = Vec3::zeros());
                    let term = potential.terms_mut().nth(k).expect("k < terms");
                    term.evaluate(&ctx, y, &v, force, &mut partials)
                };
            let mut f = vec![Vec3::zeros(); n];
            eval(&mut potential, &x, &mut f);
            let (mut fp, mut fm) = (vec![Vec3::zeros(); n], vec![Vec3::zeros(); n]);
            for _ in 0..params.directions {
                let u: Vec<Vec3> = (0..n).map(|_| rng.vector()).collect();
                let u_norm = flatten(&u).iter().map(|c| c * c).sum::<f64>().sqrt();
                let analytic = [-f.iter().zip(&u).map(|(f, u)| f.dot(u)).sum::<f64>()];
                let (e, step) = best_relative_error(&analytic, edge, force_floor * u_norm, |t| {
                    let mut scratch = vec![Vec3::zeros(); n];
                    let plus = eval(&mut potential, &axpy(&x, t, &u), &mut scratch);
                    let minus = eval(&mut potential, &axpy(&x, -t, &u), &mut scratch);
                    vec![(plus - minus) / (2.0 * t)]
                });
                worst(&mut energy_row, e, step);
                energy_row.cases += 1;
                // H·u at x: re-evaluate (linearize) at x first.
                eval(&mut potential, &x, &mut f);
                let hu = hessian_product(&mut potential, k, &ctx, &u, false);
                let (e, step) = best_relative_error(&flatten(&hu), edge, force_floor / edge, |t| {
                    eval(&mut potential, &axpy(&x, t, &u), &mut fp);
                    eval(&mut potential, &axpy(&x, -t, &u), &mut fm);
                    fp.iter()
                        .zip(&fm)
                        .flat_map(|(p, m)| {
                            ((m - p) / (2.0 * t)).iter().copied().collect::<Vec<_>>()
                        })
                        .collect()
                });
                worst(&mut force_row, e, step);
                force_row.cases += 1;
                eval(&mut potential, &x, &mut f);
                let term = potential.terms_mut().nth(k).expect("k < terms");
                if term.hessian_shape(&ctx) == HessianShape::Blocks {
                    let assembled = hessian_product(&mut potential, k, &ctx, &u, true);
                    let (a, b) = (flatten(&hu), flatten(&assembled));
                    let norm = |v: &[f64]| v.iter().map(|c| c * c).sum::<f64>().sqrt();
                    let diff: Vec<f64> = a.iter().zip(&b).map(|(a, b)| a - b).collect();
                    let e = norm(&diff) / norm(&a).max(norm(&b)).max(force_floor / edge);
                    worst(&mut assembled_row, e, 0.0);
                    assembled_row.cases += 1;
                }
            }
            rows.extend([energy_row, force_row]);
            if assembled_row.cases > 0 {
                rows.push(assembled_row);
            }
        }
    }
    rows
}

/// H·u of term k at its last evaluation: by its product, its lumped diagonal, or (`assembled`)
/// through a block matrix it was assembled into.
fn hessian_product(
    potential: &mut IncrementalPotential,
    k: usize,
    ctx: &StepContext<'_>,
    u: &[Vec3],
    assembled: bool,
) -> Vec<Vec3> {
    let n = u.len();
    let mut out = vec![Vec3::zeros(); n];
    let pattern = potential.elasticity.pattern().clone();
    let term = potential.terms_mut().nth(k).expect("k < terms");
    match term.hessian_shape(ctx) {
        HessianShape::Zero => {}
        HessianShape::LumpedDiagonal => {
            let mut d = vec![0.0; n];
            term.add_lumped_diagonal(ctx, &mut d);
            out.iter_mut()
                .zip(d.iter().zip(u))
                .for_each(|(o, (&d, u))| *o = d * u);
        }
        HessianShape::Blocks if assembled => {
            let mut extra = Vec::new();
            term.extra_blocks(&mut extra);
            let mut a = BlockCsr::zeros(pattern.with_blocks(&extra));
            term.add_to_matrix(ctx, &mut a);
            a.multiply(u, &mut out);
        }
        HessianShape::Blocks => term.add_hessian_product(ctx, u, &mut out),
    }
    out
}
