//! The default strategy: A assembled (and constrained) at every Newton iterate, CG multiplying
//! with it and preconditioned by one V-cycle of smoothed-aggregation multigrid ([`super::amg`]).
//!
//! The hierarchy is built at the first solve and kept: its numbers are refreshed on the kept
//! aggregates when CG slows down or (with contact) when the diagonal blocks outgrow the
//! smoother's D⁻¹, and everything is rebuilt when a solve ran into the CG cap or the system's
//! pattern changed. On the 5,184-tet cantilever CG with the assembled f64 matrix
//! ran a frame in 0.057 s against 0.103 s with the matrix-free product (same CG iterations).

use super::amg::{Amg, AmgParams, FineNumbers};
use super::cg::{CgError, CgInfo, CgParams, CgWorkspace, Preconditioner};
use super::sparse::Precision;
use super::state::{
    HierarchyState, MultigridState, SolverState, blocks_in, blocks_out, matrix_in, pattern_in,
    vectors_in, vectors_out,
};
use super::{AssembledMatrix, LinearSolver, LinearSolverParams, SolverReport, System};
use crate::math::Vec3;

/// The hierarchy is refreshed (numbers recomputed on the kept aggregates) when CG needed more
/// than this factor times the iterations per decade of residual reduction of the first solve
/// after the last refresh. With fixed tolerances, refreshing on 1.5× growth took 0.41 s per frame
/// on the 41,472-tet cantilever against 0.46 s refreshing at every Newton iterate and 0.76 s never
/// refreshing: a refresh costs about two solves' worth of CG iterations.
pub const AMG_REFRESH_GROWTH: f64 = 1.5;

/// With contact blocks in A: how far a vertex's diagonal block may grow past the one the
/// hierarchy's D⁻¹ came from ([`super::amg::Amg::diagonal_growth`]) before the hierarchy is
/// refreshed at the next iterate. Barrier blocks stiffen by orders of magnitude as gaps close;
/// past the smoother's bound the V-cycle stops preconditioning them and CG runs to its cap
/// before the slowdown rule can react. Measured from the matrix, so results stay the same bits.
pub const CONTACT_REFRESH_GROWTH: f64 = 2.0;

/// What [`Multigrid::prepare`] does to the hierarchy.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Action {
    /// The first build.
    Build,
    /// A build for a new pattern.
    NewPattern,
    /// A build after a capped solve.
    Rebuild,
    /// New numbers on the kept aggregates.
    Refresh,
}

/// Assembled A with a multigrid preconditioner.
pub struct Multigrid {
    matrix: AssembledMatrix,
    amg: Option<Box<Amg>>,
    params: AmgParams,
    cg: CgWorkspace,
    /// CG iterations per decade of residual reduction: of the first solve after the last build
    /// or refresh, and of the last solve.
    baseline_rate: Option<f64>,
    last_rate: f64,
    /// Whether the last CG solve stopped at its iteration cap.
    last_capped: bool,
    /// CG's starting guess, kept while A is f32 for a solve again in f64 (see
    /// [`Multigrid::solve`]).
    start: Vec<Vec3>,
    /// Whether A went to f64 after a breakdown on f32 (a checkpoint keeps it).
    f64_fallback: bool,
    report: SolverReport,
}

impl Multigrid {
    /// For systems of `vertices` vertices.
    pub fn new(params: &LinearSolverParams, vertices: usize) -> Self {
        Multigrid {
            matrix: AssembledMatrix::new(params.f32_matrix, params.matrix_precision),
            amg: None,
            params: params.amg.clone(),
            cg: CgWorkspace::new(vertices),
            baseline_rate: None,
            last_rate: 0.0,
            last_capped: false,
            start: Vec::new(),
            f64_fallback: false,
            report: SolverReport {
                name: "amg",
                ..Default::default()
            },
        }
    }

    /// The hierarchy, once built.
    pub fn amg(&self) -> Option<&Amg> {
        self.amg.as_deref()
    }

    /// CG with the assembled A, preconditioned by the hierarchy; keeps the counts the refresh
    /// rules read.
    fn solve_assembled(
        &mut self,
        b: &[Vec3],
        x: &mut [Vec3],
        free: &[Vec3],
        params: &CgParams,
    ) -> Result<CgInfo, CgError> {
        let amg = self.amg.as_deref_mut().expect("prepared before solving");
        let a = self.matrix.a.as_ref().expect("prepared before solving");
        let upper = self.matrix.upper.as_mut();
        let mut m = amg.with_matrix(a);
        let result = super::solve_assembled(a, upper, &mut m, b, x, free, params, &mut self.cg);
        let info = super::info_of(&result);
        self.last_rate = super::iterations_per_decade(info);
        self.last_capped = !info.converged;
        self.baseline_rate.get_or_insert(self.last_rate);
        result
    }
}

impl LinearSolver for Multigrid {
    fn prepare(&mut self, system: &mut dyn System, free: &[Vec3]) {
        let started = std::time::Instant::now();
        let coarse_f32 = !system.may_need_f64();
        if self.params.coarse_f32 != coarse_f32 {
            self.params.coarse_f32 = coarse_f32;
            if let Some(amg) = &mut self.amg {
                amg.allow_coarse_f32(coarse_f32);
            }
        }
        let new_pattern = self.matrix.assemble(system, free);
        let assembled = std::time::Instant::now();
        // One iteration of slack per decade, so that 2 → 4 iterations does not count as growth.
        let stale = self
            .baseline_rate
            .is_some_and(|b| self.last_rate > AMG_REFRESH_GROWTH * b + 1.0);
        // The hierarchy's numbers only ever come from a projected (positive semi-definite) A:
        // built or refreshed on the exact tangent of `adaptive`, which may be indefinite, its
        // Chebyshev smoothers and coarse factor stop being positive definite, and CG on the
        // projected A that follows broke down at every Newton iterate (a tangled ball, frame 43:
        // 147 breakdowns and no convergence, against none with the hierarchy kept). The exact A
        // is preconditioned with the hierarchy of the projected one, refreshed (when stale) from
        // the projected A assembled for it, then the exact A again, where the system asks for it
        // ([`System::refresh_while_exact`]); else the refresh waits for a projected A.
        let exact = !system.is_projected();
        // Contact's barrier blocks change by orders of magnitude from one Newton iterate to the
        // next as gaps open and close: D⁻¹ and the Chebyshev interval of the last refresh soon
        // stop bounding the current A. A hierarchy grown stale, or whose D⁻¹ the current
        // diagonal blocks have outgrown (see `CONTACT_REFRESH_GROWTH`), is then refreshed even
        // while A holds the exact tangent (from its projection), not left until a projected A
        // comes.
        let contact = system.needs_f64();
        let grown = contact
            && self.amg.as_ref().is_some_and(|amg| {
                let a = self.matrix.a.as_ref().expect("assembled");
                amg.diagonal_growth(a)
                    .is_some_and(|g| g > CONTACT_REFRESH_GROWTH)
            });
        let refresh_exact =
            exact && ((stale && (system.refresh_while_exact() || contact)) || grown);
        let action = match &self.amg {
            None => Some(Action::Build),
            // A new pattern (contact blocks came or went) has new aggregates.
            Some(_) if new_pattern => Some(Action::NewPattern),
            // A solve that ran into the CG cap says the hierarchy no longer fits A at all, not
            // that it aged: a body started collapsed onto a line builds its aggregates from
            // that degenerate A, and the growth rule never fires when the first solve is
            // already capped (a 3,560-tet ball: 2,000 CG iterations at every Newton iterate,
            // minutes per frame). Aggregates and numbers are rebuilt from the current A, or
            // from its projection while A is exact: waiting for a projected A let a stack of
            // three bodies in contact spend eight exact Newton iterates in a row at the cap.
            Some(_) if self.last_capped => Some(Action::Rebuild),
            Some(_) if stale && (!exact || refresh_exact) => Some(Action::Refresh),
            Some(_) if grown => Some(Action::Refresh),
            Some(_) => None,
        };
        let from_projected = exact
            && match action {
                Some(Action::Refresh) => refresh_exact,
                Some(Action::Rebuild) => true,
                _ => false,
            };
        if from_projected {
            self.matrix.assemble_projected(system, free);
        }
        let a = self.matrix.a.as_ref().expect("assembled");
        match (action, &mut self.amg) {
            (Some(Action::Build), amg) => {
                *amg = Some(Box::new(Amg::new_shared(
                    a,
                    system.rest_positions(),
                    free,
                    &self.params,
                )));
                self.report.builds += 1;
            }
            (Some(Action::NewPattern), Some(amg)) => {
                **amg = Amg::new_shared(a, system.rest_positions(), free, &self.params);
                self.baseline_rate = None;
                self.report.builds += 1;
                self.report.pattern_changes += 1;
            }
            (Some(Action::Rebuild), Some(amg)) => {
                **amg = Amg::new_shared(a, system.rest_positions(), free, &self.params);
                self.baseline_rate = None;
                self.last_capped = false;
                self.report.builds += 1;
            }
            (Some(Action::Refresh), Some(amg)) => {
                amg.refresh(a);
                self.baseline_rate = None;
                self.report.refreshes += 1;
            }
            _ => {}
        }
        if from_projected {
            self.matrix.assemble(system, free);
        }
        log::debug!(
            "assembly {:.4} s, preconditioner {:.4} s",
            assembled.duration_since(started).as_secs_f64(),
            assembled.elapsed().as_secs_f64()
        );
    }

    /// CG that meets negative curvature on a positive definite system whose A is f32 solves
    /// again with A in f64, which it keeps from then on: the rounding of A (about 6e-8 of each
    /// entry) can outweigh the mass term where the stiffness is huge (a body collapsed onto a
    /// line: tangents of 1e12 against masses of 1). A breakdown on an exact tangent is
    /// `adaptive`'s signal and is returned as it is.
    fn solve(
        &mut self,
        system: &mut dyn System,
        b: &[Vec3],
        x: &mut [Vec3],
        free: &[Vec3],
        params: &CgParams,
    ) -> Result<CgInfo, CgError> {
        // A as stored now: contact may hold it in f64 already (see `System::needs_f64`).
        let stored = self.matrix.a.as_ref().map(|a| a.precision());
        let f32_projected = stored == Some(Precision::F32) && system.is_projected();
        if f32_projected {
            self.start.clear();
            self.start.extend_from_slice(x);
        }
        let result = self.solve_assembled(b, x, free, params);
        if f32_projected && matches!(result, Err(CgError::NotPositiveDefinite { .. })) {
            log::info!(
                "CG met negative curvature on the f32 matrix of a positive definite system: the \
                 matrix is assembled in f64 from here on"
            );
            self.matrix.use_f64();
            self.f64_fallback = true;
            self.amg = None;
            self.baseline_rate = None;
            self.prepare(system, free);
            x.copy_from_slice(&self.start);
            return self.solve_assembled(b, x, free, params);
        }
        result
    }

    fn precondition(&mut self, r: &[Vec3], z: &mut [Vec3]) {
        match (&mut self.amg, &self.matrix.a) {
            (Some(amg), Some(a)) => amg.with_matrix(a).apply(r, z),
            _ => z.copy_from_slice(r),
        }
    }

    /// The block matrix, and the V-cycle's matrices: each level read 2·degree + 1 times
    /// (Chebyshev pre- and post-smoothing and the residual), 8 bytes per stored entry plus its
    /// index share; a shared finest level reads the system's A as stored (4 bytes an entry in
    /// f32), the coarse levels theirs.
    fn bytes_per_iteration(&self, _matrix_free_bytes: f64) -> f64 {
        let reads = (2 * self.params.smoother_degree + 1) as f64;
        let preconditioner = self.amg.as_ref().map_or(0.0, |amg| {
            let fine_entry = match (amg.fine_values(), &self.matrix.a) {
                (None, Some(a)) => a.bytes_per_block() as f64 / 9.0,
                _ => 8.0,
            };
            let coarse_entry = if amg.coarse_f32() { 4.0 } else { 8.0 };
            amg.info()
                .levels
                .iter()
                .enumerate()
                .map(|(depth, l)| {
                    let entry = if depth == 0 { fine_entry } else { coarse_entry };
                    reads * l.nonzeros as f64 * (entry + 4.0 / (l.block_size * l.block_size) as f64)
                })
                .sum::<f64>()
        });
        self.matrix.bytes() + preconditioner
    }

    fn report(&self) -> SolverReport {
        self.report.clone()
    }

    fn add_memory(&self, inventory: &mut crate::memory::Inventory) {
        self.matrix.add_memory(inventory);
        inventory.add("CG vectors", self.cg.heap_bytes());
        if let Some(amg) = &self.amg {
            amg.add_memory(inventory);
        }
    }

    fn save_state(&self) -> SolverState {
        let (generation, pattern) = self.matrix.saved();
        let hierarchy = match &self.amg {
            Some(amg) => {
                let numbers = amg.fine_numbers().unwrap_or_default();
                Some(Box::new(HierarchyState {
                    free: vectors_out(amg.fine_mask()),
                    aggregates: amg.aggregates(),
                    values: amg.fine_values().map(blocks_out).unwrap_or_default(),
                    dinv: blocks_out(&numbers.dinv),
                    bounds: numbers.bounds,
                    prolongator: numbers.prolongator,
                    second: numbers.second,
                    coarse_f32: numbers.coarse_f32,
                }))
            }
            None => None,
        };
        let r = &self.report;
        SolverState::Multigrid(MultigridState {
            generation,
            pattern,
            hierarchy,
            baseline_rate: self.baseline_rate,
            last_rate: self.last_rate,
            last_capped: self.last_capped,
            counts: [r.builds, r.refreshes, r.pattern_changes],
            f64_fallback: self.f64_fallback,
        })
    }

    fn restore_state(&mut self, saved: &SolverState, rest: &[Vec3]) -> Result<(), String> {
        let s = match saved {
            SolverState::Multigrid(s) => s,
            SolverState::Fresh => return Ok(()),
            SolverState::NotStored => {
                return Err(
                    "the checkpoint's linear-solver state belongs to another preconditioner".into(),
                );
            }
        };
        let n = rest.len();
        let pattern = s.pattern.as_ref().map(|p| pattern_in(p, n)).transpose()?;
        match (&pattern, &s.hierarchy) {
            (Some(pattern), Some(h)) => {
                if h.free.len() != n {
                    return Err("the stored multigrid mask does not fit the mesh".into());
                }
                let free = vectors_in(&h.free);
                let amg = if h.values.is_empty() {
                    // Several levels: the aggregates and the finest level's numbers.
                    let numbers = FineNumbers {
                        dinv: blocks_in(&h.dinv),
                        bounds: h.bounds,
                        prolongator: h.prolongator.clone(),
                        second: h.second.clone(),
                        coarse_f32: h.coarse_f32,
                    };
                    Amg::restored(pattern, rest, &free, &self.params, &h.aggregates, &numbers)
                } else {
                    // One level: the A it keeps.
                    let a = matrix_in(pattern.clone(), &h.values)?;
                    Amg::with_aggregates(&a, rest, &free, &self.params, &h.aggregates)
                }
                .ok_or("the stored multigrid hierarchy does not fit the mesh")?;
                self.amg = Some(Box::new(amg));
            }
            (_, None) => {}
            (None, Some(_)) => return Err("the stored multigrid hierarchy has no matrix".into()),
        }
        self.matrix.restore(s.generation, pattern);
        if s.f64_fallback {
            self.matrix.use_f64();
            self.f64_fallback = true;
        }
        self.baseline_rate = s.baseline_rate;
        self.last_rate = s.last_rate;
        self.last_capped = s.last_capped;
        [
            self.report.builds,
            self.report.refreshes,
            self.report.pattern_changes,
        ] = s.counts;
        Ok(())
    }
}
