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
mod smoother;

use std::time::Instant;

use self::aggregate::{Aggregates, MODES, NONE, aggregate, strong_neighbours, tentative};
use self::bsr::{
    Block, Block32, BlockRows, Bsr, Vector, mirror_lower, mirror_pairs, multiply_add_f32,
    multiply_transposed_f32, product_pattern, product_with_into, rows_mut,
};
use self::smoother::{Direct, chebyshev, inverse_diagonal, lanczos_bound};
use crate::linear::cg::Preconditioner;
use crate::linear::sparse::{BlockCsr, BlockPattern};
use crate::math::{Mat3, Vec3};

/// Largest coarsest level (DOFs) factored densely when coarsening stalls above
/// `max_coarse_dofs`; beyond it the coarsest level is only smoothed.
const DIRECT_LIMIT: usize = 3000;

/// AMG settings. Defaults measured on the issue-8 cantilever beams (see each field).
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
    a: Bsr<6, 6>,
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
}

/// The arguments every build takes.
struct BuildInput<'a> {
    positions: &'a [Vec3],
    free: &'a [Vec3],
    params: &'a AmgParams,
    given: Option<&'a [Aggregates]>,
    shared: bool,
}

impl Amg {
    /// Build the hierarchy for `a` (constrained: see the module docs) with the rigid-body modes
    /// of the vertices at `positions` as near-nullspace; `free` is the 0/1 mask per vertex and
    /// component (constrained components carry no mode).
    pub fn new(a: &BlockCsr, positions: &[Vec3], free: &[Vec3], params: &AmgParams) -> Amg {
        Self::build(
            a,
            BuildInput {
                positions,
                free,
                params,
                given: None,
                shared: false,
            },
        )
    }

    /// [`Amg::new`] without a copy of the finest A: it is applied through
    /// [`Amg::with_matrix`] with the current A (see the module docs). A hierarchy of one level
    /// keeps its copy all the same.
    pub fn new_shared(a: &BlockCsr, positions: &[Vec3], free: &[Vec3], params: &AmgParams) -> Amg {
        Self::build(
            a,
            BuildInput {
                positions,
                free,
                params,
                given: None,
                shared: true,
            },
        )
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
        Some(Self::build(
            a,
            BuildInput {
                positions,
                free,
                params,
                given: Some(&given),
                shared: true,
            },
        ))
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
        let mut stand_in = BlockCsr::zeros(pattern.clone());
        stand_in.add_diagonal(&vec![1.0; n]);
        let mut amg = Self::build(
            &stand_in,
            BuildInput {
                positions,
                free,
                params,
                given: Some(&given),
                shared: true,
            },
        );
        let Coarse::Transfer(t) = &mut amg.fine.coarse else {
            return None;
        };
        let second = amg.coarse.first_mut()?;
        if numbers.prolongator.len() != 18 * t.p32.len()
            || numbers.second.len() != 36 * second.a.values.len()
        {
            return None;
        }
        amg.fine.dinv.clone_from(&numbers.dinv);
        amg.fine.bounds = numbers.bounds;
        for (block, stored) in t.p32.iter_mut().zip(numbers.prolongator.chunks(18)) {
            *block = Block::<3, MODES>::from_column_slice(stored).cast::<f32>();
        }
        for (block, stored) in second.a.values.iter_mut().zip(numbers.second.chunks(36)) {
            *block = Block::from_column_slice(stored);
        }
        let (second, below) = amg.coarse.split_first_mut().expect("checked above");
        second.level.refresh(&second.a, params, below);
        let setup = amg.info.setup_seconds;
        amg.info = amg.describe();
        amg.info.setup_seconds = setup;
        Some(amg)
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
            second: second
                .a
                .values
                .iter()
                .flat_map(|b| b.iter().copied())
                .collect(),
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

    fn build(a: &BlockCsr, input: BuildInput<'_>) -> Amg {
        let started = Instant::now();
        let BuildInput {
            positions,
            free,
            params,
            given,
            shared,
        } = input;
        let n = a.rows();
        assert!(positions.len() == n && free.len() == n);
        let nullspace = rigid_modes(positions, free);
        let (fine, mut next) = Level::build(a, &nullspace, free.to_vec(), params, 0, given);
        let fine_a = (!shared || !matches!(fine.coarse, Coarse::Transfer(_))).then(|| Bsr {
            pattern: a.pattern.clone(),
            values: a.values.clone(),
            ncols: n,
        });
        let mut coarse: Vec<CoarseLevel> = Vec::new();
        while let Some((a_c, nullspace_c, mask_c)) = next {
            let depth = coarse.len() + 1;
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
        assert_eq!(a.values.len(), self.fine.blocks, "same pattern");
        match &mut self.fine_a {
            Some(own) => {
                own.values.copy_from_slice(&a.values);
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

/// What a level hands to the next: the coarse matrix, near-nullspace and kept-DOF mask.
type Coarsened = Option<(Bsr<6, 6>, Vec<Block<6, 6>>, Vec<Vector<6>>)>;

/// How a level's coarse correction is done.
#[derive(Clone, Debug)]
enum Coarse<const B: usize> {
    /// Coarsest level: dense Cholesky.
    Direct(Direct),
    /// Coarsest level too large to factor: one smoothing.
    Smooth,
    /// Restrict, recurse into the next level, prolong.
    Transfer(Box<Transfer<B>>),
}

/// The operators between a level and the next, with their fixed patterns.
#[derive(Clone, Debug)]
struct Transfer<const B: usize> {
    /// The patterns of T and P; their blocks are held in f32 (`t32`, `p32`), P's f64 values
    /// exist only inside [`Level::galerkin`].
    tentative: Bsr<B, MODES>,
    t32: Vec<Block32<B, MODES>>,
    p: Bsr<B, MODES>,
    p32: Vec<Block32<B, MODES>>,
    /// The pattern of Pᵀ (no values: its blocks are P's, `pt_map` says which) and its
    /// number of columns.
    pt: Bsr<MODES, B>,
    pt_map: Vec<u32>,
    /// The pattern of A·P; its values exist only inside [`Level::galerkin`].
    ap: Bsr<B, MODES>,
    mirror: Vec<(u32, u32)>,
    /// Coarse DOFs whose tentative column was dropped (decoupled with a unit diagonal).
    dropped: Vec<(u32, u8)>,
    bc: Vec<Vector<MODES>>,
    xc: Vec<Vector<MODES>>,
}

impl<const B: usize> Transfer<B> {
    /// The aggregates T was made from: the column of each row's block, `NONE` for rows
    /// without one, and the number of aggregates.
    fn aggregates(&self) -> (Vec<u32>, usize) {
        let t = &self.tentative;
        let of = (0..t.rows())
            .map(|i| t.row(i).next().map_or(NONE, |k| t.pattern.cols[k]))
            .collect();
        (of, t.ncols)
    }
}

/// A level's numbers and work vectors; its matrix is held beside it ([`CoarseLevel`], or the
/// finest A: see [`Amg`]) and handed to every method.
#[derive(Clone, Debug)]
struct Level<const B: usize> {
    /// Block rows and stored blocks of the level's matrix.
    rows: usize,
    blocks: usize,
    /// 0/1 per DOF: constrained (fine) or dropped (coarse) DOFs are 0; P's rows there are zero.
    mask: Vec<Vector<B>>,
    dinv: Vec<Block<B, B>>,
    bounds: (f64, f64),
    eigen_start: Vec<Vector<B>>,
    r: Vec<Vector<B>>,
    d: Vec<Vector<B>>,
    d_next: Vec<Vector<B>>,
    partials: Vec<f64>,
    degree: usize,
    coarse: Coarse<B>,
}

impl<const B: usize> Level<B> {
    /// Set up a level on `a` and decide how it is coarsened; returns the next level's data.
    fn build(
        a: &impl BlockRows<B, B>,
        nullspace: &[Block<B, MODES>],
        mask: Vec<Vector<B>>,
        params: &AmgParams,
        depth: usize,
        given: Option<&[Aggregates]>,
    ) -> (Self, Coarsened) {
        let n = a.rows();
        let mut level = Level {
            eigen_start: vec![Vector::zeros(); n],
            r: vec![Vector::zeros(); n],
            d: vec![Vector::zeros(); n],
            d_next: vec![Vector::zeros(); n],
            dinv: Vec::new(),
            bounds: (0.0, 1.0),
            partials: Vec::new(),
            degree: params.smoother_degree.max(1),
            coarse: Coarse::Smooth,
            mask,
            rows: n,
            blocks: a.pattern().blocks(),
        };
        level.update_smoother(a, params);
        let dofs = B * n;
        let last = dofs <= params.max_coarse_dofs || depth + 1 >= params.max_levels;
        let transfer = if let Some(given) = given {
            given
                .get(depth)
                .map(|aggregates| tentative(aggregates, nullspace))
        } else if last {
            None
        } else {
            let strong = strong_neighbours(a, params.strength_threshold);
            let active: Vec<bool> = nullspace
                .iter()
                .map(|b| b.iter().any(|&x| x != 0.0))
                .collect();
            let aggregates = aggregate(&strong, &active);
            let coarse_dofs = MODES * aggregates.count;
            // Coarsening that barely reduces the problem is not worth a level.
            (aggregates.count > 0 && 4 * coarse_dofs <= 3 * dofs)
                .then(|| tentative(&aggregates, nullspace))
        };
        let Some((mut tentative, nullspace_c, kept)) = transfer else {
            level.coarse = coarsest(a, params);
            return (level, None);
        };
        let nc = tentative.ncols;
        let t32 = std::mem::take(&mut tentative.values)
            .iter()
            .map(|b| b.cast::<f32>())
            .collect();
        let p = product_pattern(a, &tentative);
        let p32 = vec![Block32::zeros(); p.blocks()];
        let (pt, pt_map) = p.transpose_pattern();
        let ap = product_pattern(a, &p);
        let mut a_c = product_pattern(&pt, &ap);
        a_c.values = vec![Block::zeros(); a_c.blocks()];
        let mirror = mirror_pairs(&a_c);
        let dropped = kept
            .iter()
            .enumerate()
            .flat_map(|(g, k)| {
                (0..MODES)
                    .filter(|&c| !k[c])
                    .map(move |c| (g as u32, c as u8))
            })
            .collect();
        let mask_c = kept
            .iter()
            .map(|k| Vector::<MODES>::from_fn(|c, _| if k[c] { 1.0 } else { 0.0 }))
            .collect();
        let mut transfer = Transfer {
            tentative,
            t32,
            p,
            p32,
            pt,
            pt_map,
            ap,
            mirror,
            dropped,
            bc: vec![Vector::zeros(); nc],
            xc: vec![Vector::zeros(); nc],
        };
        level.galerkin(a, &mut transfer, &mut a_c, params);
        level.coarse = Coarse::Transfer(Box::new(transfer));
        (level, Some((a_c, nullspace_c, mask_c)))
    }

    /// D⁻¹ and the Chebyshev interval from the current A. Lanczos starts from the same fixed
    /// vector every time, so a refresh gives the same bits as a fresh build.
    fn update_smoother(&mut self, a: &impl BlockRows<B, B>, params: &AmgParams) {
        inverse_diagonal(a, &mut self.dinv);
        for (i, v) in self.eigen_start.iter_mut().enumerate() {
            *v = Vector::<B>::from_fn(|c, _| pseudo_random(B * i + c));
        }
        let upper = lanczos_bound(
            a,
            &self.dinv,
            &mut self.eigen_start,
            params.lanczos_steps.max(1),
            [&mut self.r, &mut self.d, &mut self.d_next],
            &mut self.partials,
        );
        self.bounds = (params.smoother_lower_fraction * upper, upper);
    }

    /// P = (I − ω·D⁻¹A)·T, Pᵀ, A·P and A_c = Pᵀ·(A·P) into `a_c` (on its pattern).
    fn galerkin(
        &self,
        a: &impl BlockRows<B, B>,
        t: &mut Transfer<B>,
        a_c: &mut Bsr<MODES, MODES>,
        params: &AmgParams,
    ) {
        let omega = params.prolongator_damping / self.bounds.1;
        let (dinv, mask, tent, t32) = (&self.dinv, &self.mask, &t.tentative, &t.t32);
        let (a_cols, a_values) = (&a.pattern().cols, a.values());
        // P's rows are computed in f64 and stored rounded to f32, block by block (no f64 copy of
        // P: it would stay in the resident set after the refresh). Each block sums A's row in
        // order, as a product into the whole row would. The products below read the rounded
        // blocks, so A_c is the Galerkin product of the P the cycle applies.
        rows_mut(&t.p.pattern, &mut t.p32, |i, cols, row| {
            let scale = Block::<B, B>::from_diagonal(&mask[i]);
            let left = scale * (-omega * dinv[i]);
            for (out, &c) in row.iter_mut().zip(cols) {
                let mut sum = Block::<B, MODES>::zeros();
                for k in a.row(i) {
                    let j = a_cols[k] as usize;
                    for kt in tent.row(j) {
                        if tent.pattern.cols[kt] == c {
                            sum += a_values[k] * t32[kt].cast::<f64>();
                        }
                    }
                }
                let mut v = left * sum;
                for kt in tent.row(i) {
                    if tent.pattern.cols[kt] == c {
                        v += scale * t32[kt].cast::<f64>();
                    }
                }
                *out = v.cast::<f32>();
            }
        });
        // A·P lives only here (it is the largest array of the set-up, larger than A).
        t.ap.values = vec![Block::zeros(); t.ap.blocks()];
        let p32 = &t.p32;
        product_with_into(
            a.pattern(),
            |k| a_values[k],
            &t.p.pattern,
            |k| p32[k].cast::<f64>(),
            &mut t.ap,
            false,
        );
        let (ap, map) = (&t.ap, &t.pt_map);
        product_with_into(
            &t.pt.pattern,
            |k| p32[map[k] as usize].cast::<f64>().transpose(),
            &ap.pattern,
            |k| ap.values[k],
            a_c,
            true,
        );
        t.ap.values = Vec::new();
        mirror_lower(a_c, &t.mirror);
        for &(g, c) in &t.dropped {
            let k = a_c.find(g as usize, g as usize).expect("diagonal");
            a_c.values[k][(c as usize, c as usize)] = 1.0;
        }
    }

    /// Recompute this level's numbers (A already updated) and the levels below.
    fn refresh(&mut self, a: &impl BlockRows<B, B>, params: &AmgParams, rest: &mut [CoarseLevel]) {
        self.update_smoother(a, params);
        let mut coarse = std::mem::replace(&mut self.coarse, Coarse::Smooth);
        if let Coarse::Transfer(t) = &mut coarse {
            let (next, below) = rest.split_first_mut().expect("a level below");
            self.galerkin(a, t, &mut next.a, params);
            next.level.refresh(&next.a, params, below);
        } else {
            coarse = coarsest(a, params);
        }
        self.coarse = coarse;
    }

    /// `x ≈ A⁻¹·b` by one V-cycle from x = 0.
    fn cycle(
        &mut self,
        a: &impl BlockRows<B, B>,
        b: &[Vector<B>],
        x: &mut [Vector<B>],
        rest: &mut [CoarseLevel],
    ) {
        let Level {
            dinv,
            bounds,
            r,
            d,
            d_next,
            degree,
            coarse,
            ..
        } = self;
        match coarse {
            Coarse::Direct(direct) => direct.solve(b, x),
            Coarse::Smooth => chebyshev(a, dinv, *bounds, *degree, b, x, true, [r, d, d_next]),
            Coarse::Transfer(t) => {
                chebyshev(a, dinv, *bounds, *degree, b, x, true, [r, d, d_next]);
                a.residual(b, x, r);
                multiply_transposed_f32(&t.p32, &t.pt.pattern, &t.pt_map, r, &mut t.bc);
                let (next, below) = rest.split_first_mut().expect("a level below");
                next.level.cycle(&next.a, &t.bc, &mut t.xc, below);
                multiply_add_f32(&t.p.pattern, &t.p32, &t.xc, x);
                chebyshev(a, dinv, *bounds, *degree, b, x, false, [r, d, d_next]);
            }
        }
    }

    /// Bytes this level holds, by kind.
    fn memory(&self) -> LevelMemory {
        use crate::memory::vec_bytes;
        let mut m = LevelMemory {
            matrix: 0,
            vectors: vec_bytes(&self.mask)
                + vec_bytes(&self.dinv)
                + vec_bytes(&self.eigen_start)
                + vec_bytes(&self.r)
                + vec_bytes(&self.d)
                + vec_bytes(&self.d_next)
                + vec_bytes(&self.partials),
            ..Default::default()
        };
        match &self.coarse {
            Coarse::Transfer(t) => {
                m.transfer = t.tentative.heap_bytes()
                    + vec_bytes(&t.t32)
                    + t.p.heap_bytes()
                    + vec_bytes(&t.p32)
                    + t.pt.heap_bytes()
                    + vec_bytes(&t.pt_map)
                    + vec_bytes(&t.mirror)
                    + vec_bytes(&t.dropped)
                    + vec_bytes(&t.bc)
                    + vec_bytes(&t.xc);
                m.product = t.ap.heap_bytes();
            }
            Coarse::Direct(d) => m.matrix += d.heap_bytes(),
            Coarse::Smooth => {}
        }
        m
    }

    fn is_direct(&self) -> bool {
        matches!(&self.coarse, Coarse::Direct(_))
    }

    fn describe(&self) -> LevelInfo {
        LevelInfo {
            rows: self.rows,
            block_size: B,
            nonzeros: B * B * self.blocks,
            spectral_bound: self.bounds.1,
        }
    }
}

/// Bytes a level holds: its matrix, its vectors, its transfer operators, its A·P.
#[derive(Clone, Copy, Debug, Default)]
struct LevelMemory {
    matrix: usize,
    vectors: usize,
    transfer: usize,
    product: usize,
}

/// The coarsest level's solver: dense Cholesky when small enough and it factors, else smoothing.
fn coarsest<const B: usize>(a: &impl BlockRows<B, B>, params: &AmgParams) -> Coarse<B> {
    if B * a.rows() <= DIRECT_LIMIT.max(params.max_coarse_dofs) {
        let direct = Direct::new(a);
        if direct.is_factored() {
            return Coarse::Direct(direct);
        }
    }
    Coarse::Smooth
}

/// A fixed pseudo-random number in [0.5, 1.5) for entry i (a hash, so start vectors do not
/// depend on anything but the index).
fn pseudo_random(i: usize) -> f64 {
    let mut h = (i as u64).wrapping_add(0x9E37_79B9_7F4A_7C15);
    h = (h ^ (h >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    h = (h ^ (h >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    h ^= h >> 31;
    0.5 + (h >> 11) as f64 / (1u64 << 53) as f64
}

#[cfg(test)]
mod tests;
