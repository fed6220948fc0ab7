//! The problem one Newton solve works on: the step's data ([`StepContext`]) and the incremental
//! potential as a list of terms ([`IncrementalPotential`]), which is also the linear solvers'
//! [`System`].

use rayon::prelude::*;

use super::CHUNK;
use super::params::SolverParams;
use super::scheme::Inertial;
use super::terms::{Elasticity, ExternalForces, HessianShape, Inertia, Term};
use crate::elastic::ElasticBody;
use crate::linear::sparse::{BlockCsr, BlockPattern};
use crate::linear::{System, SystemPattern};
use crate::math::{Mat3, Vec3};

/// What kind of step.
#[derive(Clone, Copy, Debug)]
pub enum StepKind<'a> {
    /// A dynamic step of the time scheme (see [`super::scheme`]).
    Dynamic(Inertial<'a>),
    /// Static equilibrium.
    Static,
}

/// Everything one step's solve reads and does not change.
#[derive(Clone, Copy)]
pub struct StepContext<'a> {
    /// The elastic body.
    pub body: &'a ElasticBody,
    /// Dynamic or static.
    pub kind: StepKind<'a>,
    /// External forces (gravity, loads) at the end of the step, N.
    pub f_ext: &'a [Vec3],
    /// 0/1 mask of the free DOFs.
    pub free: &'a [Vec3],
    /// Solver settings.
    pub params: &'a SolverParams,
}

impl StepContext<'_> {
    /// Whether Newton minimises a potential (γ = 0 or quasistatic); with γ > 0 the damping
    /// force has none and the merit is ‖rhs‖.
    pub fn has_potential(&self) -> bool {
        self.stiffness_damping() == 0.0
    }

    /// γ of the damping force −γ·K(x)·v in this step (0 when static: no velocity).
    pub fn stiffness_damping(&self) -> f64 {
        match self.kind {
            StepKind::Dynamic(_) => self.params.rayleigh_stiffness,
            StepKind::Static => 0.0,
        }
    }
}

/// The incremental potential: inertia, elasticity (with damping) and loads, then any further
/// terms (contact, friction), in that order (see [`super::terms`] for why order matters).
pub struct IncrementalPotential {
    /// Inertia and mass damping.
    pub inertia: Inertia,
    /// Elasticity and stiffness damping.
    pub elasticity: Elasticity,
    /// Gravity and dead loads.
    pub external: ExternalForces,
    /// Contact with rigid obstacles, when the scene has any.
    pub contact: Option<crate::contact::term::ContactTerm>,
    /// Further terms, evaluated after the ones above.
    pub extra: Vec<Box<dyn Term>>,
    /// The energy of every term at the last evaluation, in term order.
    energies: Vec<f64>,
    /// Lumped diagonal of the Hessian (sum of the diagonal terms), per vertex.
    diagonal: Vec<f64>,
    /// The pattern of the whole Hessian: the mesh's adjacency plus the extra terms' blocks.
    pattern: Option<(BlockPattern, u64)>,
    pattern_generations: Vec<u64>,
    pattern_generation: u64,
    scratch_pairs: Vec<(u32, u32)>,
    /// The total force on the constrained components at the last evaluation (zero on free
    /// ones), kept only when asked for (see [`IncrementalPotential::record_constrained_forces`]).
    constrained: Option<Vec<Vec3>>,
}

/// The potential with the step context of the current solve: the linear solvers' [`System`].
pub struct Problem<'p, 'c> {
    /// The terms.
    pub potential: &'p mut IncrementalPotential,
    /// The step.
    pub ctx: &'p StepContext<'c>,
}

impl IncrementalPotential {
    /// Its buffers, into a memory inventory (contact and further terms are not counted).
    pub fn add_memory(&self, inventory: &mut crate::memory::Inventory) {
        use crate::memory::vec_bytes;
        self.elasticity.add_memory(inventory);
        let pattern = self
            .pattern
            .as_ref()
            .map_or(0, |(p, _)| vec_bytes(&p.row_start) + vec_bytes(&p.cols));
        inventory.add(
            "potential: the Hessian's pattern, lumped diagonal",
            pattern + vec_bytes(&self.diagonal),
        );
    }

    /// The built-in terms for `body`.
    pub fn new(body: &ElasticBody, params: &SolverParams) -> Self {
        IncrementalPotential {
            inertia: Inertia,
            elasticity: Elasticity::new(body, params.definiteness),
            external: ExternalForces,
            contact: None,
            extra: Vec::new(),
            energies: Vec::new(),
            diagonal: vec![0.0; body.vertex_count()],
            pattern: None,
            pattern_generations: Vec::new(),
            pattern_generation: 0,
            scratch_pairs: Vec::new(),
            constrained: None,
        }
    }

    /// Keep the total force on the constrained components at every evaluation (off by
    /// default): minus it is the reaction of the constraints ([`crate::monitor`]).
    pub fn record_constrained_forces(&mut self, on: bool) {
        self.constrained = on.then(Vec::new);
    }

    /// The total force of every term on the constrained components at the last evaluation (zero
    /// on free components), N; empty unless recorded and evaluated.
    pub fn constrained_forces(&self) -> &[Vec3] {
        self.constrained.as_deref().unwrap_or(&[])
    }

    /// The generation number of the Hessian's pattern (see [`crate::linear::SystemPattern`]).
    pub fn pattern_generation(&self) -> u64 {
        self.pattern_generation
    }

    /// Continue a run whose pattern had generation `generation` (a checkpoint's): the pattern is
    /// built afresh at the next solve and numbered so.
    pub fn restore_pattern_generation(&mut self, generation: u64) {
        self.pattern = None;
        self.pattern_generations.clear();
        self.pattern_generation = generation.saturating_sub(1);
    }

    /// Every term, in order.
    pub fn terms_mut(&mut self) -> impl Iterator<Item = &mut dyn Term> {
        [
            &mut self.inertia as &mut dyn Term,
            &mut self.elasticity,
            &mut self.external,
        ]
        .into_iter()
        .chain(Self::later_terms(&mut self.contact, &mut self.extra))
    }

    /// The terms after the three built-in ones (contact, then the extra ones), in order.
    fn later_terms<'a>(
        contact: &'a mut Option<crate::contact::term::ContactTerm>,
        extra: &'a mut [Box<dyn Term>],
    ) -> impl Iterator<Item = &'a mut dyn Term> {
        contact
            .iter_mut()
            .map(|t| t as &mut dyn Term)
            .chain(extra.iter_mut().map(|t| &mut **t as &mut dyn Term))
    }

    /// The largest fraction of the move x → x + dx every term allows (see [`Term::max_step`]).
    pub fn max_step(&mut self, ctx: &StepContext<'_>, x: &[Vec3], dx: &[Vec3]) -> f64 {
        self.terms_mut()
            .map(|t| t.max_step(ctx, x, dx))
            .fold(1.0, f64::min)
    }

    /// Every term's [`Term::begin_step`], in order.
    pub fn begin_step(&mut self, start: &super::terms::StepStart<'_>, guess: &mut [Vec3]) {
        for term in self.terms_mut() {
            term.begin_step(start, guess);
        }
    }

    /// Every term's [`Term::continue_step`]: `Ok(true)` when one moved on and the step is to
    /// be solved again, the first `Err` when one cannot go on.
    pub fn continue_step(&mut self, x: &[Vec3]) -> Result<bool, String> {
        let mut again = false;
        for term in self.terms_mut() {
            again |= term.continue_step(x)?;
        }
        Ok(again)
    }

    /// Every term's [`Term::add_stats`], in order.
    pub fn add_stats(&self, stats: &mut super::stats::StepStats) {
        for term in self.later_terms_ref() {
            term.add_stats(stats);
        }
    }

    /// The largest residual floor a term asks for (see [`Term::residual_floor`]), N.
    pub fn residual_floor(&mut self, ctx: &StepContext<'_>) -> f64 {
        self.terms_mut()
            .map(|t| t.residual_floor(ctx))
            .fold(0.0, f64::max)
    }

    /// Every term's [`Term::after_first_evaluation`]: whether one of them asks for another
    /// evaluation.
    pub fn after_first_evaluation(&mut self, ctx: &StepContext<'_>, force: &[Vec3]) -> bool {
        let mut again = false;
        for term in self.terms_mut() {
            again |= term.after_first_evaluation(ctx, force);
        }
        again
    }

    /// Whether a term finds the Newton step dx small enough to stop (see
    /// [`Term::step_converged`]).
    pub fn step_converged(&mut self, ctx: &StepContext<'_>, dx: &[Vec3]) -> bool {
        self.terms_mut().any(|t| t.step_converged(ctx, dx))
    }

    /// Every term's name, in order.
    pub fn term_names(&self) -> Vec<&'static str> {
        let mut names = vec![
            self.inertia.name(),
            self.elasticity.name(),
            self.external.name(),
        ];
        names.extend(self.contact.iter().map(|t| t.name()));
        names.extend(self.extra.iter().map(|t| t.name()));
        names
    }

    /// The energy of the terms added after the built-in ones and contact (see
    /// [`crate::Simulation::add_term`]) at the last evaluation, J.
    pub fn added_energy(&self) -> f64 {
        let built_in = 3 + usize::from(self.contact.is_some());
        self.energies.iter().skip(built_in).sum()
    }

    /// The energy of each term at the last evaluation, in term order, J.
    pub fn energies(&self) -> &[f64] {
        &self.energies
    }

    /// Evaluate every term at x: `force` = the total force (masked by the free DOFs), returns the
    /// potential Φ (the sum of the terms' energies, in order).
    pub fn evaluate(
        &mut self,
        ctx: &StepContext<'_>,
        x: &[Vec3],
        v: &[Vec3],
        force: &mut [Vec3],
        partials: &mut [f64],
    ) -> f64 {
        force
            .par_iter_mut()
            .with_min_len(CHUNK)
            .for_each(|f| *f = Vec3::zeros());
        let mut energies = std::mem::take(&mut self.energies);
        energies.clear();
        for term in self.terms_mut() {
            energies.push(term.evaluate(ctx, x, v, force, partials));
        }
        self.energies = energies;
        let free = ctx.free;
        match &mut self.constrained {
            // The same pass splits the force: free components stay, constrained ones are kept.
            Some(kept) => {
                kept.resize(force.len(), Vec3::zeros());
                force
                    .par_iter_mut()
                    .zip(free.par_iter().zip(kept.par_iter_mut()))
                    .with_min_len(CHUNK)
                    .for_each(|(f, (m, k))| {
                        let on_free = f.component_mul(m);
                        *k = *f - on_free;
                        *f = on_free;
                    });
            }
            None => force
                .par_iter_mut()
                .zip(free.par_iter())
                .with_min_len(CHUNK)
                .for_each(|(f, m)| *f = f.component_mul(m)),
        }
        self.energies.iter().sum()
    }

    /// Make every term's Hessian data left for later at (x, v), the last evaluated iterate (see
    /// [`Term::linearize`]).
    pub fn linearize(&mut self, ctx: &StepContext<'_>, x: &[Vec3], v: &[Vec3]) {
        for term in self.terms_mut() {
            term.linearize(ctx, x, v);
        }
    }

    /// Use the exact Hessians (or the projected ones again) in every term.
    pub fn use_exact(&mut self, exact: bool) {
        self.terms_mut().for_each(|t| t.use_exact(exact));
    }

    /// Refill the lumped diagonal from the diagonal terms.
    fn fill_diagonal(&mut self, ctx: &StepContext<'_>) {
        let mut diagonal = std::mem::take(&mut self.diagonal);
        diagonal.iter_mut().for_each(|d| *d = 0.0);
        for term in self.terms_mut() {
            if term.hessian_shape(ctx) == HessianShape::LumpedDiagonal {
                term.add_lumped_diagonal(ctx, &mut diagonal);
            }
        }
        self.diagonal = diagonal;
    }

    /// The terms after the three built-in ones, read-only (see [`Self::later_terms`]).
    fn later_terms_ref(&self) -> impl Iterator<Item = &dyn Term> {
        self.contact
            .iter()
            .map(|t| t as &dyn Term)
            .chain(self.extra.iter().map(|t| &**t as &dyn Term))
    }

    /// Rebuild the Hessian's pattern when a later term's blocks changed (contact pairs between
    /// body vertices, extra terms).
    fn refresh_pattern(&mut self) {
        let generations: Vec<u64> = self
            .later_terms_ref()
            .map(|t| t.pattern_generation())
            .collect();
        if self.pattern.is_some() && generations == self.pattern_generations {
            return;
        }
        let base = self.elasticity.pattern();
        let mut scratch = std::mem::take(&mut self.scratch_pairs);
        scratch.clear();
        for term in self.later_terms_ref() {
            term.extra_blocks(&mut scratch);
        }
        self.scratch_pairs = scratch;
        let pattern = if self.scratch_pairs.is_empty() {
            base.clone()
        } else {
            base.with_blocks(&self.scratch_pairs)
        };
        let unchanged = self.pattern.as_ref().is_some_and(|(p, _)| *p == pattern);
        if !unchanged {
            self.pattern_generation += 1;
            self.pattern = Some((pattern, self.pattern_generation));
        }
        self.pattern_generations = generations;
    }
}

impl<'p, 'c> Problem<'p, 'c> {
    /// The system at the potential's last evaluation.
    pub fn new(potential: &'p mut IncrementalPotential, ctx: &'p StepContext<'c>) -> Self {
        potential.fill_diagonal(ctx);
        potential.refresh_pattern();
        Problem { potential, ctx }
    }
}

impl System for Problem<'_, '_> {
    fn len(&self) -> usize {
        self.potential.diagonal.len()
    }

    fn apply(&mut self, p: &[Vec3], out: &mut [Vec3]) {
        let ctx = self.ctx;
        out.par_iter_mut()
            .with_min_len(CHUNK)
            .for_each(|o| *o = Vec3::zeros());
        for term in self.potential.terms_mut() {
            if term.hessian_shape(ctx) == HessianShape::Blocks {
                term.add_hessian_product(ctx, p, out);
            }
        }
        let d = &self.potential.diagonal;
        out.par_iter_mut()
            .zip(p.par_iter().zip(d.par_iter()))
            .with_min_len(CHUNK)
            .for_each(|(o, (p, &d))| *o += d * p);
    }

    fn diagonal_blocks(&mut self, out: &mut [Mat3]) {
        let ctx = self.ctx;
        out.par_iter_mut()
            .with_min_len(CHUNK)
            .for_each(|o| *o = Mat3::zeros());
        for term in self.potential.terms_mut() {
            if term.hessian_shape(ctx) == HessianShape::Blocks {
                term.add_diagonal_blocks(ctx, out);
            }
        }
        let d = &self.potential.diagonal;
        out.par_iter_mut()
            .zip(d.par_iter())
            .with_min_len(CHUNK)
            .for_each(|(o, &d)| *o += Mat3::from_diagonal_element(d));
    }

    fn pattern(&self) -> SystemPattern<'_> {
        let (pattern, generation) = self
            .potential
            .pattern
            .as_ref()
            .expect("refreshed when the problem was made");
        SystemPattern {
            pattern,
            generation: *generation,
        }
    }

    fn assemble(&mut self, a: &mut BlockCsr) {
        // Elasticity lays the matrix down (its pass over each row zeroes the row first), the
        // other block terms add to it, the lumped diagonal comes last.
        let ctx = self.ctx;
        let p = &mut *self.potential;
        p.elasticity.write_matrix(ctx, a);
        // Inertia is diagonal and the loads have no Hessian: the block terms after elasticity.
        for term in IncrementalPotential::later_terms(&mut p.contact, &mut p.extra) {
            if term.hessian_shape(ctx) == HessianShape::Blocks {
                term.add_to_matrix(ctx, a);
            }
        }
        a.add_diagonal(&self.potential.diagonal);
    }

    fn rest_positions(&self) -> &[Vec3] {
        &self.ctx.body.mesh.positions
    }

    fn is_projected(&self) -> bool {
        !self.potential.elasticity.linearization().exact_in_use()
    }

    /// In damped steps `adaptive` solves with the exact tangent from the first iterate (see
    /// [`super::policy`]): the projected A may never come, so the hierarchy is refreshed from it.
    fn refresh_while_exact(&self) -> bool {
        self.ctx.stiffness_damping() > 0.0
    }

    /// A contact (or another later) term, pairs or not.
    fn may_need_f64(&self) -> bool {
        self.potential.later_terms_ref().next().is_some()
    }

    /// Contact pairs (or another later block term) in the Hessian.
    fn needs_f64(&self) -> bool {
        self.potential
            .later_terms_ref()
            .any(|t| t.hessian_shape(self.ctx) == HessianShape::Blocks)
    }

    fn assemble_projected(&mut self, a: &mut BlockCsr) {
        let exact = !self.is_projected();
        if exact {
            self.potential.use_exact(false);
        }
        self.assemble(a);
        if exact {
            self.potential.use_exact(true);
        }
    }
}
