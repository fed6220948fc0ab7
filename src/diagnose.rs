//! Diagnosis in words: what went wrong in a run, where, and what to try. The run summary of
//! `tetsim run` is [`RunSummary`]; [`plausibility_warnings`] flags suspicious parameters before a
//! run starts; [`inverted_elements`] names the inverted tets of a state.

use std::fmt;

use crate::boundary::Boundary;
use crate::elastic::ElasticBody;
use crate::integrator::{SolverParams, StepStats};
use crate::material::{Definiteness, Material};
use crate::math::{Mat3, Vec3};

/// How many element ids a message lists.
pub const LISTED: usize = 8;

/// The inverted tets (det F ≤ 0) of state x: their count and the ids (file ids when the mesh
/// came from a file) of the first [`LISTED`].
pub fn inverted_elements(body: &ElasticBody, x: &[Vec3]) -> (usize, Vec<u64>) {
    let j = body.jacobians(x);
    let inverted: Vec<usize> = (0..j.len()).filter(|&t| j[t] <= 0.0).collect();
    let ids = inverted
        .iter()
        .take(LISTED)
        .map(|&t| body.mesh.tet_id(t))
        .collect();
    (inverted.len(), ids)
}

/// "N tets are inverted (ids a, b, c, …)" or None.
pub fn describe_inverted(body: &ElasticBody, x: &[Vec3]) -> Option<String> {
    let (count, ids) = inverted_elements(body, x);
    (count > 0).then(|| {
        let list: Vec<String> = ids.iter().map(u64::to_string).collect();
        format!(
            "{count} of {} tets are inverted (elements {}{})",
            body.tet_count(),
            list.join(", "),
            if count > ids.len() { ", …" } else { "" }
        )
    })
}

/// Static strain ρ·|g|·L/E above which a body is said to collapse under its own weight: its base
/// would be compressed by more than half (L is the body's extent along gravity).
pub const COLLAPSE_STRAIN: f64 = 0.5;

/// Warnings about parameters that are legal but suspicious, in words (also logged by the CLI).
pub fn plausibility_warnings(
    body: &ElasticBody,
    boundary: &Boundary,
    params: &SolverParams,
) -> Vec<String> {
    let mut warnings = Vec::new();
    let g = boundary.gravity.norm();
    let mut df = Mat3::zeros();
    df[(0, 0)] = 1.0;
    // λ + 2μ, the stiffness of a laterally confined column: a scale for E.
    let modulus = body
        .model
        .stress_differential(&Mat3::identity(), &df)
        .norm();
    let (lo, hi) = body.mesh.bounding_box();
    let size = (hi - lo).norm();
    if g > 0.0 && modulus > 0.0 {
        let along = (hi - lo).abs().dot(&(boundary.gravity / g).abs());
        let strain = body.density * g * along / modulus;
        if strain > COLLAPSE_STRAIN {
            let wave_time = along / (modulus / body.density).sqrt();
            warnings.push(format!(
                "the body is so soft it collapses under its own weight: ρ·g·L/E = {strain:.2} \
                 (ρ = {} kg/m³, L = {along:.3e} m along gravity, E ≈ {modulus:.3e} Pa){}; \
                 check the units of youngs_modulus (Pa) and of the mesh (m)",
                body.density,
                if params.integrator.is_dynamic() && params.dt > wave_time {
                    format!(
                        ", and within one frame (dt = {} s > L/c = {wave_time:.2e} s)",
                        params.dt
                    )
                } else {
                    String::new()
                }
            ));
        }
    }
    if let Some(w) = locking_warning(body) {
        warnings.push(w);
    }
    if params.integrator.is_dynamic() && size > 0.0 {
        let fall = 0.5 * g * params.dt * params.dt;
        if fall > size {
            warnings.push(format!(
                "one frame of free fall ({fall:.3e} m at dt = {} s) is longer than the body \
                 ({size:.3e} m): expect large, heavily damped steps",
                params.dt
            ));
        }
    }
    warnings
}

/// A run that ends folded: at rest, nothing holding it deformed (no gravity, loads, prescribed
/// motions or obstacles), yet storing elastic energy above that of a 1 % strain everywhere. A
/// start mirrored or scrambled through itself can settle in such a state with every tet
/// positively oriented (258 J on a 1 m³ block of the default material): Neo-Hookean's energy has
/// minima besides rest once tets have passed through inversion. Returns the finding in words.
pub fn folded_finding(
    body: &ElasticBody,
    boundary: &Boundary,
    contact: bool,
    x: &[Vec3],
    kinetic: f64,
) -> Option<String> {
    let driven = boundary.gravity != Vec3::zeros()
        || !boundary.loads.is_empty()
        || contact
        || boundary.constraints.iter().any(|c| {
            c.until.is_none()
                && (c.motion.translate != Vec3::zeros() || c.motion.rotate_degrees != 0.0)
        });
    if driven {
        return None;
    }
    let mut df = Mat3::zeros();
    df[(0, 1)] = 1.0;
    let mu = body.model.stress_differential(&Mat3::identity(), &df)[(0, 1)];
    let volume: f64 = body.masses().iter().sum::<f64>() / body.density;
    let scale = mu * volume * FOLDED_STRAIN * FOLDED_STRAIN;
    let stored = body.energy(x);
    (stored > scale && kinetic < 1e-3 * stored).then(|| {
        let advice = if body.has_recovery() {
            "its tangled elements were evaluated with Irving's clamp until no vertex lay inside \
             another tet, yet it settled here: a larger [material] recovery_threshold (0.7, 0.8) \
             holds the clamp over more of the fold (see docs/user-guide.md on tangled starts)"
                .to_string()
        } else {
            "a model with a recovery form for tangled elements (\"neo-hookean\", \
             \"mooney-rivlin\") recovers from such starts"
                .to_string()
        };
        format!(
            "the body ended folded: at rest with nothing holding it, it still stores {stored:.3e} J \
             of elastic energy (a 1 % strain everywhere would be {scale:.1e} J), so it settled in \
             a state other than its rest shape, likely from a start that passed tets through \
             inversion; {advice}"
        )
    })
}

/// Strain whose energy everywhere marks a body at rest as folded (see [`folded_finding`]).
const FOLDED_STRAIN: f64 = 0.01;

/// Newton iterations per step from which a frame counts as slow (for the clamping note).
pub const SLOW_NEWTON: usize = 8;

/// λ/μ above which linear tets are said to lock (ν > 0.499).
pub const LOCKING_RATIO: f64 = 499.0;

/// A warning for a nearly incompressible material (λ/μ > [`LOCKING_RATIO`], ν > 0.499): linear
/// tets lock and Newton stiffens. λ and μ are read off the rest tangent, whatever the model.
pub fn locking_warning(body: &ElasticBody) -> Option<String> {
    let rest = |i: usize, j: usize| {
        let mut df = Mat3::zeros();
        df[(i, j)] = 1.0;
        body.model.stress_differential(&Mat3::identity(), &df)[(i, j)]
    };
    let mu = rest(0, 1);
    let lambda = rest(0, 0) - 2.0 * mu;
    let ratio = lambda / mu;
    (mu > 0.0 && ratio > LOCKING_RATIO).then(|| {
        let nu = lambda / (2.0 * (lambda + mu));
        if body.mesh.is_quadratic() {
            format!(
                "the material is nearly incompressible (ν = {nu:.7}, λ/μ = {ratio:.1e}): \
                 quadratic tets bend right, but Newton stiffens (many iterations, slow CG); \
                 expect it to be slow, raise substeps if frames do not converge"
            )
        } else {
            format!(
                "the material is nearly incompressible (ν = {nu:.7}, λ/μ = {ratio:.1e}): linear \
                 tets lock (the body bends far too little) and Newton stiffens (many iterations, \
                 slow CG, frames that may not converge). Set [mesh] order = 2 (quadratic tets, \
                 which do not lock), or use poisson_ratio = 0.45-0.49 unless volume must be \
                 kept exactly"
            )
        }
    })
}

/// Everything a run did, gathered frame by frame, and told in words at the end.
#[derive(Clone, Debug, Default)]
pub struct RunSummary {
    /// Frames done.
    pub frames: usize,
    /// Newton and CG iterations over the run.
    pub newton: usize,
    /// CG iterations over the run.
    pub cg: usize,
    /// Frames that did not converge, with the first reason.
    pub unconverged: Vec<(usize, String)>,
    /// Frames that needed more substeps than asked (step cutting), with the substeps used.
    pub cut: Vec<(usize, usize)>,
    /// CG solves that hit their cap, and that broke down (pᵀAp ≤ 0).
    pub cg_capped: usize,
    /// CG solves that broke down.
    pub cg_breakdowns: usize,
    /// Line-search halvings over the run.
    pub line_search_cuts: usize,
    /// Most tets strongly clamped at once (beyond rounding) in a slow or failed frame, and the
    /// frame.
    pub most_clamped: (usize, usize),
    /// Frames whose energy audit found energy created, with the joules.
    pub energy_injected: Vec<(usize, f64)>,
    /// Smallest det F over the run and the frame.
    pub min_j: (f64, usize),
    /// Worst relative residual.
    pub worst_residual: f64,
}

impl RunSummary {
    /// Fold one frame in.
    pub fn add(&mut self, s: &StepStats, asked_substeps: usize) {
        if self.frames == 0 {
            self.min_j = (f64::INFINITY, 0);
        }
        self.frames += 1;
        self.newton += s.newton_iterations;
        self.cg += s.cg_iterations;
        if !s.converged {
            let why = s.failure.clone().unwrap_or_else(|| "unknown".into());
            self.unconverged.push((s.frame, why));
        }
        if s.substeps > asked_substeps {
            self.cut.push((s.frame, s.substeps));
        }
        self.cg_capped += s.cg_capped;
        self.cg_breakdowns += s.cg_breakdowns;
        self.line_search_cuts += s.line_search_cuts;
        // Clamping explains slow Newton; on a frame that converged quickly it is no news.
        let slow = !s.converged || s.newton_iterations >= SLOW_NEWTON * s.substeps.max(1);
        if slow && s.strongly_clamped_tets > self.most_clamped.0 {
            self.most_clamped = (s.strongly_clamped_tets, s.frame);
        }
        let injected = s.energy.injected();
        if injected > 0.0 {
            self.energy_injected.push((s.frame, injected));
        }
        if s.min_j < self.min_j.0 {
            self.min_j = (s.min_j, s.frame);
        }
        self.worst_residual = self.worst_residual.max(s.relative_residual);
    }

    /// The findings, each a sentence with what to try; empty when the run was clean.
    pub fn findings(&self, body: &ElasticBody, x: &[Vec3], params: &SolverParams) -> Vec<String> {
        let mut out = Vec::new();
        let frames = |list: &mut dyn Iterator<Item = usize>| {
            let v: Vec<String> = list.take(LISTED).map(|f| f.to_string()).collect();
            v.join(", ")
        };
        if let Some((first, why)) = self.unconverged.first() {
            out.push(format!(
                "{} frame(s) did not converge (frames {}{}); frame {first}: {why}. Try more \
                 substeps or a smaller dt, a looser newton_tolerance, or more \
                 newton_max_iterations",
                self.unconverged.len(),
                frames(&mut self.unconverged.iter().map(|u| u.0)),
                if self.unconverged.len() > LISTED {
                    ", …"
                } else {
                    ""
                }
            ));
        }
        if !self.cut.is_empty() {
            let most = self.cut.iter().map(|c| c.1).max().unwrap_or(0);
            out.push(format!(
                "{} frame(s) were retried with smaller steps (frames {}; up to {most} substeps): \
                 dt is large for this body; substeps = {most} would avoid the retries",
                self.cut.len(),
                frames(&mut self.cut.iter().map(|c| c.0)),
            ));
        }
        if self.cg_capped > 0 {
            out.push(format!(
                "CG stopped at its cap of {} iterations in {} solve(s) (the Newton step was then \
                 inexact): raise cg_max_iterations or try preconditioner = \"block-jacobi\"",
                params.cg.max_iterations, self.cg_capped
            ));
        }
        if self.cg_breakdowns > 0 {
            out.push(if params.definiteness == Definiteness::Exact {
                format!(
                    "CG met negative curvature (pᵀAp ≤ 0) in {} solve(s): with definiteness = \
                     \"exact\" the stiffness is indefinite far from rest; \"projected\" keeps it \
                     positive semi-definite",
                    self.cg_breakdowns
                )
            } else {
                format!(
                    "CG broke down in {} solve(s) although the tangent is projected: the system \
                     is badly conditioned (a huge stiffness contrast or time step); try a smaller \
                     dt or more substeps",
                    self.cg_breakdowns
                )
            });
        }
        if self.most_clamped.0 > 0 {
            let (count, frame) = self.most_clamped;
            out.push(format!(
                "in frames that took {SLOW_NEWTON} or more Newton iterations a step, up to {count} \
                 of {} tets ({:.1} %, frame {frame}) had their tangent clamped by more than 1 % of \
                 its stiffness to stay positive definite (Teran 2005): they were compressed, \
                 inverted or strongly stretched, which slows Newton there",
                body.tet_count(),
                100.0 * count as f64 / body.tet_count() as f64
            ));
        }
        if let Some(text) = describe_inverted(body, x) {
            out.push(format!(
                "at the end, {text}: an inverted body recovers under its own elasticity given \
                 time; if it stays inverted, its boundary conditions may force it"
            ));
        }
        if !self.energy_injected.is_empty() {
            let total: f64 = self.energy_injected.iter().map(|e| e.1).sum();
            out.push(format!(
                "ENERGY INJECTED: {} frame(s) (frames {}) gave back {total:.3e} J more than \
                 loads and boundaries put in, beyond rounding and the Newton residual: the \
                 earliest sign of a wrong derivative or an unstable step; run `tetsim check` on \
                 this scene, and try a smaller dt",
                self.energy_injected.len(),
                frames(&mut self.energy_injected.iter().map(|e| e.0)),
            ));
        }
        out
    }
}

impl fmt::Display for RunSummary {
    /// One line: frames, iterations, worst residual, min J.
    fn fmt(&self, out: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            out,
            "{} frames: {} Newton iterations ({:.1}/frame), {} CG iterations ({:.0}/Newton), \
             worst relative residual {:.1e}, min J {:.3} (frame {})",
            self.frames,
            self.newton,
            self.newton as f64 / self.frames.max(1) as f64,
            self.cg,
            self.cg as f64 / self.newton.max(1) as f64,
            self.worst_residual,
            self.min_j.0,
            self.min_j.1
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::material::{Lame, Model, ModelKind};
    use crate::mesh::generate::box_mesh;

    fn cube() -> ElasticBody {
        let mesh = box_mesh(Vec3::zeros(), Vec3::repeat(1.0), [2, 2, 2]);
        let lame = Lame {
            mu: 3.8e4,
            lambda: 5.8e4,
        };
        ElasticBody::new(mesh, Model::new(ModelKind::NeoHookean, lame), 1000.0).unwrap()
    }

    #[test]
    fn a_body_left_deformed_with_nothing_holding_it_is_said_folded() {
        let body = cube();
        let free = Boundary {
            constraints: Vec::new(),
            loads: Vec::new(),
            gravity: Vec3::zeros(),
        };
        let rest = body.mesh.positions.clone();
        assert!(folded_finding(&body, &free, false, &rest, 0.0).is_none());
        let stretched: Vec<Vec3> = rest.iter().map(|p| 1.2 * p).collect();
        let said = folded_finding(&body, &free, false, &stretched, 0.0).expect("folded");
        assert!(said.contains("recovery_threshold"), "{said}");
        // Moving, or held by gravity or an obstacle: not a verdict.
        assert!(folded_finding(&body, &free, false, &stretched, 1e6).is_none());
        assert!(folded_finding(&body, &free, true, &stretched, 0.0).is_none());
        let weighed = Boundary {
            gravity: Vec3::new(0.0, -9.81, 0.0),
            ..free
        };
        assert!(folded_finding(&body, &weighed, false, &stretched, 0.0).is_none());
    }
}
