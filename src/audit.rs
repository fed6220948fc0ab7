//! The energy audit: where every joule of a step came from and went, so that energy injection
//! (the earliest sign of a wrong derivative or an unstable step) is caught and said.
//!
//! **Backward Euler**, one step (xⁿ, vⁿ) → (xⁿ⁺¹, vⁿ⁺¹) with Δx = xⁿ⁺¹ − xⁿ = h·vⁿ⁺¹. Its equation
//! on every degree of freedom is `M(vⁿ⁺¹ − vⁿ)/h = f_el + f_d + f_g + f_load + R − r`, with R the
//! reaction that keeps constrained components on their prescribed path (nonzero only there) and
//! r the Newton residual left on free ones. Dotting with Δx:
//!
//! ```text
//! ΔK + ΔE + ΔV = W_load + W_bound − D_damp − D_num
//! K = ½vᵀMv, E = Σ WΨ, V = −Σ m g·x,
//! W_load = f_load(tⁿ⁺¹)·Δx, W_bound = R·Δx, D_damp = h·vⁿ⁺¹ᵀ(γK + αM)vⁿ⁺¹,
//! D_num = ½‖vⁿ⁺¹ − vⁿ‖²_M + (E(xⁿ) − E(xⁿ⁺¹) − ∇E(xⁿ⁺¹)·(xⁿ − xⁿ⁺¹)) + r·Δx
//! ```
//!
//! D_num, backward Euler's own numerical dissipation, is what remains: positive for a convex
//! energy and a converged step. A remainder below −tolerance means the step created energy, and
//! is flagged. The tolerance is |r·Δx|, plus rounding relative to the energies in play (the
//! levels K and E at both ends, not only their changes: a cube gliding at 1 m/s carries 600 J
//! whose rounding alone is 1e-13 J a step), plus what a non-convex energy may give back: the
//! Bregman term E(xⁿ) − E(xⁿ⁺¹) − ∇E(xⁿ⁺¹)·(xⁿ − xⁿ⁺¹) is then negative, by about the
//! trapezoid estimate ½(f_el(xⁿ) − f_el(xⁿ⁺¹))·Δx (tets crushed inside out, a bar twisted past
//! buckling). That estimate uses forces, not energies, so a wrong derivative (forces that are
//! not −∇E) still shows in the remainder, and invented kinetic energy is flagged whatever the
//! curvature. Half the estimate's size is allowed on top for its own error.
//!
//! **Other schemes** (see [`crate::integrator::scheme`]): the same balance with the scheme's
//! inertia force `m·(v − ṽ)/τ_a` in the reaction and the damping's work over Δx. The remainder is
//! then that scheme's numerical dissipation: BDF2's, smaller than backward Euler's; Newmark's
//! average-acceleration rule keeps the energy of a linear undamped body, so its remainder is zero
//! up to Newton's residual and, for a nonlinear one, the trapezoid's third-order error, which
//! the curvature allowance below covers.
//!
//! **Contact** (see [`crate::contact::term::ContactAccount`]): the barrier B is a level beside
//! E, a moving obstacle's work `B(xⁿ, oⁿ⁺¹) − B(xⁿ, oⁿ)` joins the boundary work, friction's
//! work f_friction·Δx joins the loads', the contact force at the end counts in the reactions, and
//! the barrier's Bregman term joins the elastic one (with its own trapezoid estimate).
//!
//! **Quasistatic** (no inertia, loads and gravity ramped): `ΔE = W_load + W_bound − D_num`, the
//! works by the trapezoid rule over the load step (gravity counts as a load). D_num is then the
//! quadrature error as well, of either sign; it is flagged only beyond 5 % of the works.

use crate::elastic::ElasticBody;
use crate::math::Vec3;

/// Energy terms of one frame (summed over its substeps), J. The end-of-frame energies are
/// levels; works and dissipations are what the frame added.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct EnergyAudit {
    /// Gravitational potential V = −Σ m g·x at the end of the frame (quasistatic: of the
    /// ramped gravity, for reference; its work is in `load_work`).
    pub gravitational: f64,
    /// Work of the dead loads (quasistatic: and of gravity) over the frame.
    pub load_work: f64,
    /// Work of the prescribed motions (reactions · displacement of constrained components) and
    /// of moving obstacles.
    pub boundary_work: f64,
    /// Energy taken by Rayleigh damping over the frame.
    pub damping_dissipation: f64,
    /// The remainder: backward Euler's numerical dissipation (≥ −tolerance when healthy).
    pub numerical_dissipation: f64,
    /// How far below zero the remainder may go before it counts as injected energy.
    pub tolerance: f64,
}

impl EnergyAudit {
    /// Add one substep's works, dissipations and tolerance; keep its levels.
    pub fn add(&mut self, step: &EnergyAudit) {
        self.gravitational = step.gravitational;
        self.load_work += step.load_work;
        self.boundary_work += step.boundary_work;
        self.damping_dissipation += step.damping_dissipation;
        self.numerical_dissipation += step.numerical_dissipation;
        self.tolerance += step.tolerance;
    }

    /// Energy created beyond tolerance (J, 0 when none): the step gave back more than the
    /// loads and boundaries put in.
    pub fn injected(&self) -> f64 {
        (-self.numerical_dissipation - self.tolerance).max(0.0)
    }
}

/// What the audit carries from one step to the next: the elastic energy of the current state and,
/// for the quasistatic trapezoid rule, the loads and reactions there.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Ledger {
    /// E(x) of the current state, J.
    pub elastic: f64,
    /// Dead loads (and ramped gravity) at the current state, N (quasistatic).
    pub loads: Vec<Vec3>,
    /// Reactions at the current state, N (quasistatic).
    pub reactions: Vec<Vec3>,
    /// Elastic forces f_el at the current state, N (empty when unknown: then no allowance for a
    /// non-convex energy is made).
    pub forces: Vec<Vec3>,
    /// The damping force's magnitude γ·K·v + α·M·v at the current state, N, kept for schemes
    /// that balance the forces at both ends of a step (empty: zero).
    pub damping: Vec<Vec3>,
    /// The energy of the terms a library user added ([`crate::Simulation::add_term`]) at the
    /// current state, J.
    pub added: f64,
}

/// Everything one step's audit reads. Slices are per vertex.
pub struct StepRecord<'a> {
    /// The body (masses).
    pub body: &'a ElasticBody,
    /// 0/1 mask of free components.
    pub free: &'a [Vec3],
    /// Gravity of the step (ramped when quasistatic), m/s².
    pub gravity: Vec3,
    /// External forces of the step: gravity plus dead loads, N.
    pub f_ext: &'a [Vec3],
    /// Positions and velocities at the start of the step.
    pub xn: &'a [Vec3],
    /// Velocities at the start (ignored when quasistatic).
    pub vn: &'a [Vec3],
    /// Positions and velocities at the end.
    pub x: &'a [Vec3],
    /// Velocities at the end.
    pub v: &'a [Vec3],
    /// f_el at the end, N.
    pub f_el: &'a [Vec3],
    /// K·v at the end (used only when γ > 0), N/s.
    pub kv: &'a [Vec3],
    /// Newton's residual at the end (zero on constrained components), N.
    pub residual: &'a [Vec3],
    /// E at the end, J.
    pub elastic: f64,
    /// The energy of added terms at the end, J: stored energy beside E.
    pub added: f64,
    /// The step as its time scheme made it, and the Rayleigh coefficients γ (s), α (1/s); None
    /// when quasistatic.
    pub dynamic: Option<(crate::integrator::Inertial<'a>, f64, f64)>,
    /// With contact: its forces at the end (N) and its share of the balance.
    pub contact: Option<(&'a [Vec3], crate::contact::term::ContactAccount)>,
}

/// Relative rounding allowance on the sum of the magnitudes of all terms.
const ROUNDING: f64 = 1e-9;

/// The share of the trapezoid curvature estimate allowed for its own error.
const CURVATURE_ERROR: f64 = 0.5;

/// Newmark: the share of the curvature term its quadrature error of the elastic work may reach
/// before a remainder counts (that error is third order in h, the curvature second).
const TRAPEZOID_ERROR: f64 = 0.05;

/// Quasistatic: the share of the works the trapezoid rule may miss before a remainder counts.
const QUADRATURE: f64 = 0.05;

/// The audit of one step; updates `ledger` to the end state.
pub fn audit_step(r: &StepRecord<'_>, ledger: &mut Ledger) -> EnergyAudit {
    let sums = audit_sums(r, ledger);
    audit_finish(&sums)
}

/// The sums over the vertices (and the elastic energies) one step's audit is made of, in
/// [`audit_finish`]'s order. Under MPI each rank sums its own vertices and the sums are added
/// over the ranks before [`audit_finish`] (see [`crate::parallel`]). Updates `ledger`'s
/// per-vertex parts and its elastic energy to the end state.
pub fn audit_sums(r: &StepRecord<'_>, ledger: &mut Ledger) -> AuditSums {
    let masses = r.body.masses();
    let n = masses.len();
    let (mut load_work, mut boundary_work, mut damping, mut kinetic_change) = (0.0, 0.0, 0.0, 0.0);
    let (mut residual_work, mut gravitational) = (0.0, 0.0);
    let (mut potential_change, mut kinetic_level, mut curvature) = (0.0, 0.0, 0.0);
    let (mut scheme_allowance, mut trapezoidal) = (0.0, 0.0);
    let curvature_known = ledger.forces.len() == n;
    let quasistatic = r.dynamic.is_none();
    ledger.loads.resize(n, Vec3::zeros());
    ledger.reactions.resize(n, Vec3::zeros());
    if !quasistatic {
        ledger.damping.resize(n, Vec3::zeros());
    }
    // Plain loops in vertex order: deterministic, and cheap next to one Newton iteration. Many
    // parallel slices are read at the same index, so an index loop is the clear form.
    #[allow(clippy::needless_range_loop)]
    for i in 0..n {
        let (m, dx) = (masses[i], r.x[i] - r.xn[i]);
        let fixed = Vec3::repeat(1.0) - r.free[i];
        let gravity_force = m * r.gravity;
        // Every force but the reaction, at the end of the step.
        let applied = r.f_el[i] + r.f_ext[i] + r.contact.map_or(Vec3::zeros(), |(f, _)| f[i]);
        let load = r.f_ext[i] - gravity_force;
        gravitational -= gravity_force.dot(&r.x[i]);
        residual_work += r.residual[i].dot(&dx);
        if curvature_known {
            curvature += 0.5 * (ledger.forces[i] - r.f_el[i]).dot(&dx);
        }
        match r.dynamic {
            Some((step, gamma, alpha)) => {
                let (v, vn) = (r.v[i], r.vn[i]);
                let inertia = m * (v - step.base_velocity[i]) / step.inertia_time;
                let reaction =
                    (inertia + alpha * m * v + gamma * r.kv[i] - applied).component_mul(&fixed);
                let damping_force = gamma * r.kv[i] + alpha * m * v;
                let w = step.start_weight;
                if w == 0.0 {
                    load_work += load.dot(&dx);
                    boundary_work += reaction.dot(&dx);
                } else {
                    // The works as the scheme weighs them: (1 − w)·end + w·start.
                    load_work += ((1.0 - w) * load + w * ledger.loads[i]).dot(&dx);
                    boundary_work += ((1.0 - w) * reaction + w * ledger.reactions[i]).dot(&dx);
                    damping += w * (ledger.damping[i] - damping_force).dot(&dx);
                }
                ledger.loads[i] = load;
                ledger.reactions[i] = reaction;
                ledger.damping[i] = damping_force;
                damping += if step.displacement_is_hv {
                    step.h * v.dot(&damping_force)
                } else {
                    dx.dot(&damping_force)
                };
                kinetic_change += 0.5 * m * (v.norm_squared() - vn.norm_squared());
                if let Some(previous) = step.previous_velocity {
                    // BDF2's own kinetic level ¼(‖vⁿ⁺¹‖² + ‖2vⁿ⁺¹ − vⁿ‖²)_M falls where ½‖v‖²_M
                    // may rise for a step: their changes' difference is allowed.
                    let g = |a: Vec3, b: Vec3| (2.0 * a - b).norm_squared() - a.norm_squared();
                    scheme_allowance += (0.25 * m * (g(v, vn) - g(vn, previous[i]))).abs();
                }
                if let Some((start, excess)) = step.start_acceleration {
                    // Newmark with β ≠ γ/2: Δx differs from h(vⁿ + vⁿ⁺¹)/2 by (β − γ/2)h²Δa.
                    let a = step.acceleration(i, &v);
                    let mean = (1.0 - step.start_weight) * a + step.start_weight * start[i];
                    scheme_allowance +=
                        (excess * step.h * step.h * m * (a - start[i]).dot(&mean)).abs();
                }
                if step.start_weight > 0.0 {
                    trapezoidal = 1.0;
                }
                kinetic_level += 0.5 * m * (v.norm_squared() + vn.norm_squared());
                potential_change -= gravity_force.dot(&dx);
            }
            None => {
                let reaction = -applied.component_mul(&fixed);
                load_work += 0.5 * (ledger.loads[i] + r.f_ext[i]).dot(&dx);
                boundary_work += 0.5 * (ledger.reactions[i] + reaction).dot(&dx);
                ledger.loads[i] = r.f_ext[i];
                ledger.reactions[i] = reaction;
            }
        }
    }
    let contact = r.contact.map(|(_, c)| c).unwrap_or_default();
    let (mut stored_end, mut stored_start) = (
        r.elastic + contact.barrier_end,
        ledger.elastic + contact.barrier_start,
    );
    if r.added != 0.0 || ledger.added != 0.0 {
        stored_end += r.added;
        stored_start += ledger.added;
    }
    ledger.added = r.added;
    let sums = [
        load_work + contact.friction_work,
        boundary_work + contact.obstacle_work,
        damping,
        kinetic_change,
        residual_work,
        gravitational,
        potential_change,
        kinetic_level,
        // Newmark: the barrier's work by the trapezoid is no Bregman term to allow for.
        curvature
            + if trapezoidal > 0.0 {
                0.0
            } else {
                contact.curvature
            },
        stored_end,
        stored_start,
        if quasistatic { 1.0 } else { 0.0 },
        scheme_allowance,
        trapezoidal,
    ];
    ledger.elastic = r.elastic;
    ledger.forces.clear();
    ledger.forces.extend_from_slice(r.f_el);
    sums
}

/// The sums of [`audit_sums`]: load work, boundary work, damping, kinetic change, residual
/// work, gravitational energy, potential change, kinetic level, curvature, stored energy
/// (elastic, and the barrier's with contact) at the end and at the start, 1 for a quasistatic
/// step (0 otherwise), the scheme's own allowance (BDF2's two-step kinetic level, Newmark's
/// β ≠ γ/2), and 1 for a step that balances the forces at both ends (Newmark's).
pub type AuditSums = [f64; 14];

/// The audit from its sums (added over the ranks under MPI; a quasistatic flag summed over
/// N ranks is N).
pub fn audit_finish(sums: &AuditSums) -> EnergyAudit {
    let [
        load_work,
        boundary_work,
        damping,
        kinetic_change,
        residual_work,
        gravitational,
        potential_change,
        kinetic_level,
        curvature,
        elastic,
        elastic_before,
        quasistatic,
        scheme_allowance,
        trapezoidal,
    ] = *sums;
    let quasistatic = quasistatic > 0.0;
    let elastic_change = elastic - elastic_before;
    let remainder =
        load_work + boundary_work - damping - (kinetic_change + elastic_change + potential_change);
    let magnitude = load_work.abs()
        + boundary_work.abs()
        + damping.abs()
        + kinetic_level
        + elastic.abs()
        + elastic_before.abs()
        + potential_change.abs();
    // What a non-convex stretch may give back, plus half the curvature term for the trapezoid
    // estimate's own (third-order) error: on scenes/squash_release.toml's frame 15 (tets crushed
    // inside out as the plate stops) the remainder is −21.0 J against an estimate of −21.4 J.
    // A step that weighs the forces at both ends (Newmark) has no Bregman term to allow for:
    // its remainder is the quadrature error of the work, of either sign, and energy it creates
    // (a stiff barrier or sticking friction under the trapezoidal rule) is flagged.
    let convexity = if trapezoidal > 0.0 {
        TRAPEZOID_ERROR * curvature.abs()
    } else {
        (-curvature).max(0.0) + CURVATURE_ERROR * curvature.abs()
    };
    let mut tolerance = residual_work.abs() + ROUNDING * magnitude + convexity + scheme_allowance;
    if quasistatic {
        tolerance += QUADRATURE * (load_work.abs() + boundary_work.abs() + elastic_change.abs());
    }
    EnergyAudit {
        gravitational,
        load_work,
        boundary_work,
        damping_dissipation: damping,
        numerical_dissipation: remainder,
        tolerance,
    }
}

/// [`audit_finish`] with the elastic Bregman term estimated by Simpson's rule instead of the
/// trapezoid: from the elastic forces' work over the step `f(xⁿ)·Δx`, `f(x_mid)·Δx` and
/// `f(xⁿ⁺¹)·Δx` (x_mid halfway). With g′(t) = −f(xⁿ + tΔx)·Δx the Bregman term is
/// `∫₀¹ (g′(1) − g′(t)) dt`; the trapezoid gives ½(f(xⁿ) − f(xⁿ⁺¹))·Δx (the sums' estimate),
/// Simpson `g′(1) − (g′(0) + 4g′(½) + g′(1))/6`, exact for a quartic energy along the step. Still
/// made of forces only, so a wrong derivative shows as before; used for steps the trapezoid
/// flags (serial runs), whose cost is one more force evaluation.
pub fn audit_refined(sums: &AuditSums, start: f64, middle: f64, end: f64) -> EnergyAudit {
    let trapezoid = 0.5 * (start - end);
    let simpson = -end + (start + 4.0 * middle + end) / 6.0;
    let mut refined = *sums;
    refined[8] += simpson - trapezoid;
    audit_finish(&refined)
}

/// V = −Σ m g·x, J.
pub fn gravitational_energy(body: &ElasticBody, gravity: Vec3, x: &[Vec3]) -> f64 {
    -body
        .masses()
        .iter()
        .zip(x)
        .map(|(m, x)| m * gravity.dot(x))
        .sum::<f64>()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A step along which the energy is −t⁶ (a bar past buckling: concave along the step), no
    /// kinetic energy left over: the remainder is the Bregman term, −5 J. The trapezoid estimate
    /// (−3 J) allows 4.5 J and flags the step; Simpson's (−4.875 J) allows enough. Forces of the
    /// wrong sign (a convex claim for a concave energy) are still flagged after the refinement.
    #[test]
    fn simpson_clears_a_concave_step_the_trapezoid_flags_but_not_wrong_forces() {
        // g(t) = E(xⁿ + tΔx) = −t⁶; the forces' work w(t) = −g′(t) = 6t⁵.
        let (start, middle, end) = (0.0, 6.0 / 32.0, 6.0);
        let trapezoid = 0.5 * (start - end);
        let mut sums: AuditSums = [0.0; 14];
        sums[3] = 6.0; // kinetic change, so that the remainder −(ΔK + ΔE) is −5 J
        sums[7] = 6.0; // kinetic level
        sums[8] = trapezoid;
        sums[9] = -1.0; // E at the end
        sums[10] = 0.0; // E at the start
        assert!((audit_finish(&sums).numerical_dissipation + 5.0).abs() < 1e-12);
        assert!(audit_finish(&sums).injected() > 0.4);
        assert_eq!(audit_refined(&sums, start, middle, end).injected(), 0.0);
        // The same energies with forces that say the opposite.
        let mut wrong = sums;
        wrong[8] = -trapezoid;
        assert!(audit_refined(&wrong, -start, -middle, -end).injected() > 1.0);
    }
}
