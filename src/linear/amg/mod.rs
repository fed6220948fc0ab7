//! Smoothed-aggregation algebraic multigrid (Vaněk, Mandel and Brezina 1996) for the assembled
//! elasticity system, used as a CG preconditioner.
//!
//! **Hierarchy.** From the fine matrix A (3×3 blocks, one per vertex pair, Dirichlet DOFs already
//! decoupled by [`BlockCsr::constrain`]) and the near-nullspace N (per vertex the 3 translations
//! and 3 infinitesimal rotations `eₖ × (x − c)/L`, zero on constrained components):
//! - strong connections `‖A_ij‖_F > θ·√(‖A_ii‖_F·‖A_jj‖_F)`, greedy aggregation;
//! - tentative prolongator T by a QR of N per aggregate (`N = T·N_c`), so coarse nodes carry the
//!   6 rigid modes: coarse levels have 6×6 blocks;
//! - smoothed prolongator `P = (I − ω·D⁻¹A)·T`, `ω = 4/(3·ρ(D⁻¹A))`, D the block diagonal;
//! - Galerkin coarse operator `A_c = Pᵀ·A·P` (upper half computed, mirrored: exactly symmetric);
//! - until at most `max_coarse_dofs` remain, factored by a dense Cholesky.
//!
//! **Cycle.** A V-cycle with Chebyshev smoothing on D⁻¹A (bounds by Lanczos), the same before
//! and after the coarse correction, so the preconditioner is symmetric positive definite.
//!
//! **Reuse.** While the pattern stays (Newton iterates, frames), [`Amg::refresh`] keeps the
//! aggregates, T and every sparsity pattern and recomputes the numbers: D⁻¹, the spectral bounds,
//! P, Pᵀ, A·P and Pᵀ·A·P, and the coarse factor.
//!
//! **The finest A.** A hierarchy made by [`Amg::new`] keeps a copy of the A of its last build or
//! refresh and smooths with it. One made by [`Amg::new_shared`] (the solver's) keeps none: its
//! finest level smooths and forms residuals with the A it is handed at each application
//! ([`Amg::with_matrix`], the CG's current A), while D⁻¹, the Chebyshev interval, P and the coarse
//! levels stay those of the last build or refresh. That saves a copy of A (about 200 bytes per
//! tet), and the V-cycle stays symmetric positive definite while the current A's spectrum under
//! D⁻¹ stays below the bound (the refresh rule renews both when CG slows down). A checkpoint
//! then stores those numbers instead of the A they came from ([`Amg::fine_numbers`],
//! [`Amg::restored`]). A hierarchy of one level (a small mesh solved by the dense factor) keeps
//! its copy: it is small, and the factor is a function of it.
//!
//! **Determinism.** Aggregation is sequential; every parallel kernel computes rows independently
//! and reductions sum fixed chunks in order: the same bits for any thread count. `apply`
//! allocates nothing (every level holds its work vectors).

mod aggregate;
mod bsr;
mod coarse;
mod level;
mod restrict;
mod smoother;

use std::time::Instant;

use self::aggregate::{Aggregates, MODES, NONE};
use self::bsr::{Block, Bsr};
use self::coarse::CoarseMatrix;
use self::level::{Coarse, Level, LevelMemory};
use crate::linear::cg::Preconditioner;
use crate::linear::sparse::{BlockCsr, BlockPattern, Precision};
use crate::math::{Mat3, Vec3};

/// Largest coarsest level (DOFs) factored densely when coarsening stalls above
/// `max_coarse_dofs`; beyond it the coarsest level is only smoothed.
const DIRECT_LIMIT: usize = 3000;

/// AMG settings. Defaults measured on the benchmark cantilever beams (see each field).
#[derive(Clone, Debug, PartialEq)]
pub struct AmgParams {
    /// Strength threshold θ: j is a strong neighbour of i when
    /// `‖A_ij‖_F > θ·√(‖A_ii‖_F·‖A_jj‖_F)`. 0 keeps every mesh neighbour. Default 0.03: on the
    /// cantilever beams (n = 6, 12, 20) PCG to 1e-6 took 8, 10, 11 iterations against 9, 13, 16
    /// with θ = 0, at the same operator complexity (1.40–1.47); θ = 0.08 cuts the aggregates too
    /// small (complexity 2–3, slower), so stay well below it.
    pub strength_threshold: f64,
    /// Chebyshev degree of each pre- and post-smoothing (products with A per smoothing).
    /// Default 2: degree 1 took 19 iterations on the n = 12 beam against 13, degree 3 took 11 but
    /// each cycle costs a product more: no faster.
    pub smoother_degree: usize,
    /// The Chebyshev interval is `[fraction·λ̄, λ̄]`, λ̄ the upper bound of λ(D⁻¹A): the smoother
    /// damps that upper part of the spectrum, the coarse levels the rest. Default 0.1 (16 → 14
    /// iterations at n = 20 against 0.3; 0.03 is no better).
    pub smoother_lower_fraction: f64,
    /// ω·λ̄ of the prolongator smoother `(I − ω·D⁻¹A)`. Default 4/3 (the classical choice,
    /// minimising the energy of the smoothed basis functions' high modes).
    pub prolongator_damping: f64,
    /// Stop coarsening at or below this many DOFs; that level is solved by dense Cholesky.
    /// Default 600: 200 or 1500 changed neither iterations nor cost measurably on the beams
    /// (their coarsest levels have 100–450 DOFs).
    pub max_coarse_dofs: usize,
    /// At most this many levels. Default 10.
    pub max_levels: usize,
    /// Lanczos steps for the spectral bound of each level. Default 10.
    pub lanczos_steps: usize,
    /// Store the levels below the finest in f32 when the hierarchy is built or refreshed on an
    /// f32 A (see `coarse.rs`). Default true; the multigrid solver turns it off for systems
    /// that may hold contact ([`crate::linear::System::may_need_f64`]).
    pub coarse_f32: bool,
}

impl Default for AmgParams {
    fn default() -> Self {
        AmgParams {
            strength_threshold: 0.03,
            smoother_degree: 2,
            smoother_lower_fraction: 0.1,
            prolongator_damping: 4.0 / 3.0,
            max_coarse_dofs: 600,
            max_levels: 10,
            lanczos_steps: 10,
            coarse_f32: true,
        }
    }
}

/// One level of the hierarchy, as reported by [`Amg::info`].
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LevelInfo {
    /// Block rows (vertices at level 0, aggregates below).
    pub rows: usize,
    /// DOFs per block row (3 at level 0, 6 below).
    pub block_size: usize,
    /// Stored scalar entries of the level's matrix.
    pub nonzeros: usize,
    /// The upper bound of λ(D⁻¹A) the smoother uses.
    pub spectral_bound: f64,
}

/// What the hierarchy looks like and what it cost.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct AmgInfo {
    /// Finest first.
    pub levels: Vec<LevelInfo>,
    /// Σ nonzeros over levels / nonzeros of level 0.
    pub operator_complexity: f64,
    /// Whether the coarsest level is solved exactly (dense Cholesky) rather than smoothed.
    pub coarsest_direct: bool,
    /// Seconds spent in [`Amg::new`].
    pub setup_seconds: f64,
    /// Seconds spent in the last [`Amg::refresh`] (0 before any).
    pub refresh_seconds: f64,
}

/// A smoothed-aggregation AMG hierarchy for one matrix pattern; a [`Preconditioner`] (one
/// V-cycle per application).
#[derive(Clone, Debug)]
pub struct Amg {
    params: AmgParams,
    /// The A the finest level smooths with, as of the last build or refresh; None when the
    /// hierarchy uses the caller's current A instead (see the module docs).
    fine_a: Option<Bsr<3, 3>>,
    fine: Level<3>,
    coarse: Vec<CoarseLevel>,
    info: AmgInfo,
}

/// A level below the finest: its matrix (a Galerkin product, the hierarchy's own) and the rest.
#[derive(Clone, Debug)]
struct CoarseLevel {
    a: CoarseMatrix,
    level: Level<6>,
}

/// The numbers of a shared hierarchy's finest level that a rebuild on its aggregates could only
/// recompute from the A of its last build or refresh, which it does not keep: with them (and the
/// aggregates) [`Amg::restored`] gives the same bits. What a checkpoint stores.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FineNumbers {
    /// D⁻¹ of the finest level, one 3×3 block per vertex.
    pub dinv: Vec<Mat3>,
    /// The finest level's Chebyshev interval.
    pub bounds: (f64, f64),
    /// The finest level's prolongator blocks (3×6, column-major, 18 numbers each).
    pub prolongator: Vec<f64>,
    /// The second level's matrix blocks (6×6, column-major, 36 numbers each).
    pub second: Vec<f64>,
    /// Whether the coarse matrices are stored in f32 (see `coarse.rs`): a hierarchy built on
    /// an f32 A.
    pub coarse_f32: bool,
}

impl Amg {
    /// Build the hierarchy for `a` (constrained: see the module docs) with the rigid-body modes
    /// of the vertices at `positions` as near-nullspace; `free` is the 0/1 mask per vertex and
    /// component (constrained components carry no mode).
    pub fn new(a: &BlockCsr, positions: &[Vec3], free: &[Vec3], params: &AmgParams) -> Amg {
        Self::build(a, positions, free, params, None, false)
    }

    /// [`Amg::new`] without a copy of the finest A: it is applied through
    /// [`Amg::with_matrix`] with the current A (see the module docs). A hierarchy of one level
    /// keeps its copy all the same.
    pub fn new_shared(a: &BlockCsr, positions: &[Vec3], free: &[Vec3], params: &AmgParams) -> Amg {
        Self::build(a, positions, free, params, None, true)
    }

    /// The hierarchy [`Amg::new_shared`] builds, on given aggregates (those of
    /// [`Amg::aggregates`], one list per level above the coarsest) instead of aggregates found
    /// from `a`: the same bits as a build on the matrix those aggregates came from followed by a
    /// refresh with `a`. What a checkpoint restores for a hierarchy of one level (see
    /// [`crate::linear::state`]). None when the aggregates do not fit `a`.
    pub fn with_aggregates(
        a: &BlockCsr,
        positions: &[Vec3],
        free: &[Vec3],
        params: &AmgParams,
        aggregates: &[(Vec<u32>, usize)],
    ) -> Option<Amg> {
        let given = given_aggregates(a.rows(), aggregates)?;
        Some(Self::build(a, positions, free, params, Some(&given), true))
    }

    /// A shared hierarchy (see [`Amg::new_shared`]) on `pattern` as it was when
    /// [`Amg::aggregates`] and [`Amg::fine_numbers`] were read off it: the same bits. None when
    /// they do not fit the pattern (or describe a hierarchy of one level, which
    /// [`Amg::with_aggregates`] restores).
    pub fn restored(
        pattern: &BlockPattern,
        positions: &[Vec3],
        free: &[Vec3],
        params: &AmgParams,
        aggregates: &[(Vec<u32>, usize)],
        numbers: &FineNumbers,
    ) -> Option<Amg> {
        let n = pattern.rows();
        let given = given_aggregates(n, aggregates)?;
        if given.is_empty() || numbers.dinv.len() != n {
            return None;
        }
        // The structure (T, the patterns, the coarse levels' shapes) depends on the pattern and
        // the aggregates only: build it on a stand-in A (identity blocks on the diagonal), then
        // put the stored numbers in and recompute the levels below from the second one's A, as
        // the refresh that made them did.
        let precision = if numbers.coarse_f32 {
            Precision::F32
        } else {
            Precision::F64
        };
        let mut stand_in = BlockCsr::zeros_in(pattern.clone(), precision);
        stand_in.add_diagonal(&vec![1.0; n]);
        let mut amg = Self::build(&stand_in, positions, free, params, Some(&given), true);
        let Coarse::Transfer(t) = &mut amg.fine.coarse else {
            return None;
        };
        let second = amg.coarse.first_mut()?;
        if numbers.prolongator.len() != 18 * t.p32.len()
            || numbers.second.len() != 36 * second.a.blocks()
        {
            return None;
        }
        amg.fine.dinv.clone_from(&numbers.dinv);
        amg.fine.bounds = numbers.bounds;
        for (block, stored) in t.p32.iter_mut().zip(numbers.prolongator.chunks(18)) {
            *block = Block::<3, MODES>::from_column_slice(stored).cast::<f32>();
        }
        second.a.set_column_major(&numbers.second);
        let (second, below) = amg.coarse.split_first_mut().expect("checked above");
        second.level.refresh(&second.a, params, below);
        let setup = amg.info.setup_seconds;
        amg.info = amg.describe();
        amg.info.setup_seconds = setup;
        Some(amg)
    }

    /// How far the diagonal blocks of `a` have grown past those the finest level's D⁻¹ came
    /// from: the largest ‖D⁻¹ᵢ·Aᵢᵢ‖_F/√3 over the vertices (1 where a block is unchanged). Past
    /// 2 or so the smoother's spectral bound no longer holds where they grew (contact barriers
    /// stiffening). None when the level keeps no D⁻¹ of this size.
    pub fn diagonal_growth(&self, a: &BlockCsr) -> Option<f64> {
        use rayon::prelude::*;
        let dinv = &self.fine.dinv;
        if dinv.len() != a.rows() {
            return None;
        }
        let growth = (0..a.rows())
            .into_par_iter()
            .map(|i| (dinv[i] * a.diagonal(i)).norm())
            .reduce(|| 0.0, f64::max);
        Some(growth / 3f64.sqrt())
    }

    /// What [`Amg::restored`] needs beside the aggregates; None for a hierarchy that keeps its
    /// finest A (one level, or made by [`Amg::new`]: [`Amg::fine_values`] then).
    pub fn fine_numbers(&self) -> Option<FineNumbers> {
        let Coarse::Transfer(t) = &self.fine.coarse else {
            return None;
        };
        if self.fine_a.is_some() {
            return None;
        }
        let second = self.coarse.first()?;
        Some(FineNumbers {
            dinv: self.fine.dinv.clone(),
            bounds: self.fine.bounds,
            prolongator: t
                .p32
                .iter()
                .flat_map(|b| b.iter().map(|&x| x as f64))
                .collect(),
            second: second.a.column_major(),
            coarse_f32: second.a.is_f32(),
        })
    }

    /// The 0/1 mask of free DOFs the hierarchy was built with (a checkpoint stores it).
    pub fn fine_mask(&self) -> &[Vec3] {
        &self.fine.mask
    }

    /// This hierarchy as a preconditioner whose finest level smooths with `a` (the current A),
    /// unless it keeps its own copy (see the module docs).
    pub fn with_matrix<'a>(&'a mut self, a: &'a BlockCsr) -> WithMatrix<'a> {
        WithMatrix { amg: self, a }
    }

    /// Each level's aggregates (finest first; the coarsest level has none): the aggregate of
    /// each row, or `u32::MAX`, and the number of aggregates. Read off the tentative
    /// prolongators, which hold one block per aggregated row.
    pub fn aggregates(&self) -> Vec<(Vec<u32>, usize)> {
        let mut out = Vec::new();
        if let Coarse::Transfer(t) = &self.fine.coarse {
            out.push(t.aggregates());
        }
        for level in &self.coarse {
            if let Coarse::Transfer(t) = &level.level.coarse {
                out.push(t.aggregates());
            }
        }
        out
    }

    /// The hierarchy on `a`, on `given` aggregates or its own; `shared`: without a copy of the
    /// finest A (see [`Amg::new_shared`]).
    fn build(
        a: &BlockCsr,
        positions: &[Vec3],
        free: &[Vec3],
        params: &AmgParams,
        given: Option<&[Aggregates]>,
        shared: bool,
    ) -> Amg {
        let started = Instant::now();
        let n = a.rows();
        assert!(positions.len() == n && free.len() == n);
        let nullspace = rigid_modes(positions, free);
        let (fine, mut next) = Level::build(a, &nullspace, free.to_vec(), params, 0, given);
        let fine_a = (!shared || !matches!(fine.coarse, Coarse::Transfer(_))).then(|| Bsr {
            pattern: a.pattern.clone(),
            values: a.blocks_f64(),
            ncols: n,
        });
        let mut coarse: Vec<CoarseLevel> = Vec::new();
        let coarse_f32 = coarse_in_f32(params, a);
        while let Some((a_c, nullspace_c, mask_c)) = next {
            let depth = coarse.len() + 1;
            let a_c = CoarseMatrix::new(a_c, coarse_f32);
            let (level, more) = Level::build(&a_c, &nullspace_c, mask_c, params, depth, given);
            coarse.push(CoarseLevel { a: a_c, level });
            next = more;
        }
        let mut amg = Amg {
            params: params.clone(),
            fine_a,
            fine,
            coarse,
            info: AmgInfo::default(),
        };
        amg.info = amg.describe();
        amg.info.setup_seconds = started.elapsed().as_secs_f64();
        amg
    }

    /// Recompute every numeric part for new values of A on the same pattern (and the same
    /// constrained DOFs): the aggregates, T and the patterns are kept.
    pub fn refresh(&mut self, a: &BlockCsr) {
        let started = Instant::now();
        assert_eq!(a.pattern.blocks(), self.fine.blocks, "same pattern");
        // The coarse levels follow A's storage (see `coarse.rs`), as a fresh build would.
        let coarse_f32 = coarse_in_f32(&self.params, a);
        for level in &mut self.coarse {
            level.a.set_precision(coarse_f32);
        }
        match &mut self.fine_a {
            Some(own) => {
                own.values = a.blocks_f64();
                self.fine.refresh(own, &self.params, &mut self.coarse);
            }
            None => self.fine.refresh(a, &self.params, &mut self.coarse),
        }
        let setup = self.info.setup_seconds;
        self.info = self.describe();
        self.info.setup_seconds = setup;
        self.info.refresh_seconds = started.elapsed().as_secs_f64();
    }

    /// The fine matrix's blocks the hierarchy's numbers were last computed from, when it keeps
    /// them (a checkpoint stores them: see [`crate::linear::state`]).
    pub fn fine_values(&self) -> Option<&[Mat3]> {
        self.fine_a.as_ref().map(|a| a.values.as_slice())
    }

    /// The hierarchy's arrays by kind, into a memory inventory.
    pub fn add_memory(&self, inventory: &mut crate::memory::Inventory) {
        let mut fine = self.fine.memory();
        fine.matrix += self.fine_a.as_ref().map_or(0, Bsr::heap_bytes);
        inventory.add(
            "AMG: copy of the fine A (f64; none when shared) and its pattern",
            fine.matrix,
        );
        inventory.add("AMG: fine smoother and work vectors", fine.vectors);
        inventory.add(
            "AMG: fine T and P (f32), patterns of P and Pᵀ",
            fine.transfer,
        );
        inventory.add(
            "AMG: fine A·P's pattern (its values live only in a refresh)",
            fine.product,
        );
        let coarse = self.coarse.iter().fold(LevelMemory::default(), |s, l| {
            let mut m = l.level.memory();
            m.matrix += l.a.heap_bytes();
            LevelMemory {
                matrix: s.matrix + m.matrix,
                vectors: s.vectors + m.vectors,
                transfer: s.transfer + m.transfer,
                product: s.product + m.product,
            }
        });
        inventory.add(
            "AMG: coarse levels (matrices, transfers, vectors, factor)",
            coarse.matrix + coarse.vectors + coarse.transfer + coarse.product,
        );
    }

    /// Allow or forbid f32 coarse matrices from the next refresh on ([`AmgParams::coarse_f32`]).
    pub fn allow_coarse_f32(&mut self, allowed: bool) {
        self.params.coarse_f32 = allowed;
    }

    /// Whether the levels below the finest hold their matrices in f32 (see `coarse.rs`).
    pub fn coarse_f32(&self) -> bool {
        self.coarse.first().is_some_and(|l| l.a.is_f32())
    }

    /// Levels, sizes, operator complexity and timings.
    pub fn info(&self) -> &AmgInfo {
        &self.info
    }

    fn describe(&self) -> AmgInfo {
        let mut levels = vec![self.fine.describe()];
        levels.extend(self.coarse.iter().map(|l| l.level.describe()));
        let total: usize = levels.iter().map(|l| l.nonzeros).sum();
        let coarsest_direct = match self.coarse.last() {
            Some(level) => level.level.is_direct(),
            None => self.fine.is_direct(),
        };
        AmgInfo {
            operator_complexity: total as f64 / levels[0].nonzeros.max(1) as f64,
            levels,
            coarsest_direct,
            setup_seconds: 0.0,
            refresh_seconds: 0.0,
        }
    }
}

impl Preconditioner for Amg {
    /// One V-cycle from z = 0: `z ≈ A⁻¹·r`, with the hierarchy's own finest A (a shared
    /// hierarchy is applied through [`Amg::with_matrix`]).
    fn apply(&mut self, r: &[Vec3], z: &mut [Vec3]) {
        let a = self
            .fine_a
            .as_ref()
            .expect("a shared hierarchy is applied with_matrix");
        self.fine.cycle(a, r, z, &mut self.coarse);
    }
}

/// A hierarchy and the current A its finest level smooths with (see [`Amg::with_matrix`]).
pub struct WithMatrix<'a> {
    amg: &'a mut Amg,
    a: &'a BlockCsr,
}

impl Preconditioner for WithMatrix<'_> {
    /// One V-cycle from z = 0: `z ≈ A⁻¹·r`.
    fn apply(&mut self, r: &[Vec3], z: &mut [Vec3]) {
        let amg = &mut *self.amg;
        match &amg.fine_a {
            Some(own) => amg.fine.cycle(own, r, z, &mut amg.coarse),
            None => amg.fine.cycle(self.a, r, z, &mut amg.coarse),
        }
    }
}

/// Whether a hierarchy built or refreshed on `a` stores its coarse matrices in f32: when
/// allowed and A itself is f32 (see `coarse.rs`).
fn coarse_in_f32(params: &AmgParams, a: &BlockCsr) -> bool {
    params.coarse_f32 && a.precision() == Precision::F32
}

/// Stored aggregates as the build takes them, checked: each level's aggregates number that
/// level's rows, and the next level has as many rows as this one has aggregates.
fn given_aggregates(rows: usize, aggregates: &[(Vec<u32>, usize)]) -> Option<Vec<Aggregates>> {
    let mut rows = rows;
    for (of, count) in aggregates {
        if of.len() != rows || of.iter().any(|&g| g != NONE && g as usize >= *count) {
            return None;
        }
        rows = *count;
    }
    Some(
        aggregates
            .iter()
            .map(|(of, count)| Aggregates {
                of: of.clone(),
                count: *count,
            })
            .collect(),
    )
}

/// Per vertex, the 3×6 near-nullspace block: translations eₖ and rotations `eₖ × (x − c)/L`
/// (c the centroid, L the largest half-extent, so entries are O(1)), with constrained rows zero.
fn rigid_modes(positions: &[Vec3], free: &[Vec3]) -> Vec<Block<3, MODES>> {
    let n = positions.len().max(1) as f64;
    let centroid = positions.iter().fold(Vec3::zeros(), |s, p| s + p) / n;
    let extent = positions
        .iter()
        .map(|p| (p - centroid).amax())
        .fold(0.0, f64::max);
    let scale = if extent > 0.0 { 1.0 / extent } else { 1.0 };
    positions
        .iter()
        .zip(free)
        .map(|(p, m)| {
            let q = (p - centroid) * scale;
            let mut b = Block::<3, MODES>::zeros();
            for k in 0..3 {
                b[(k, k)] = 1.0;
            }
            // Columns 3..6: e_x × q, e_y × q, e_z × q.
            for k in 0..3 {
                let rot = Vec3::ith(k, 1.0).cross(&q);
                b.set_column(3 + k, &rot);
            }
            for r in 0..3 {
                if m[r] == 0.0 {
                    b.row_mut(r).fill(0.0);
                }
            }
            b
        })
        .collect()
}

#[cfg(test)]
mod tests;
