//! One level of the hierarchy: its smoother's numbers and work vectors, the transfer operators
//! to the next level (T, P and their patterns), the Galerkin product and the V-cycle's step.

use super::aggregate::{Aggregates, MODES, NONE, aggregate, strong_neighbours, tentative};
use super::bsr::{
    Block, Block32, BlockRows, Bsr, ROW_CHUNK, Vector, mirror_lower, mirror_pairs,
    multiply_add_f32, product_pattern, product_with_into,
};
use super::restrict::Restriction;
use super::smoother::{Direct, chebyshev, inverse_diagonal, lanczos_bound};
use super::{AmgParams, CoarseLevel, DIRECT_LIMIT, LevelInfo};
use crate::linear::sparse::for_each_row;

/// What a level hands to the next: the coarse matrix, near-nullspace and kept-DOF mask.
pub(super) type Coarsened = Option<(Bsr<6, 6>, Vec<Block<6, 6>>, Vec<Vector<6>>)>;

/// How a level's coarse correction is done.
#[derive(Clone, Debug)]
pub(super) enum Coarse<const B: usize> {
    /// Coarsest level: dense Cholesky.
    Direct(Direct),
    /// Coarsest level too large to factor: one smoothing.
    Smooth,
    /// Restrict, recurse into the next level, prolong.
    Transfer(Box<Transfer<B>>),
}

/// The operators between a level and the next, with their fixed patterns.
#[derive(Clone, Debug)]
pub(super) struct Transfer<const B: usize> {
    /// The patterns of T and P; their blocks are held in f32 (`t32`, `p32`), P's f64 values
    /// exist only inside [`Level::galerkin`].
    pub(super) tentative: Bsr<B, MODES>,
    pub(super) t32: Vec<Block32<B, MODES>>,
    pub(super) p: Bsr<B, MODES>,
    pub(super) p32: Vec<Block32<B, MODES>>,
    /// The pattern of Pᵀ (no values: its blocks are P's, `pt_map` says which) and its
    /// number of columns.
    pub(super) pt: Bsr<MODES, B>,
    pub(super) pt_map: Vec<u32>,
    /// The cycle's `Pᵀ·r`, read in P's row order.
    pub(super) restriction: Restriction<MODES>,
    /// The pattern of A·P; its values exist only inside [`Level::galerkin`].
    pub(super) ap: Bsr<B, MODES>,
    pub(super) mirror: Vec<(u32, u32)>,
    /// Coarse DOFs whose tentative column was dropped (decoupled with a unit diagonal).
    pub(super) dropped: Vec<(u32, u8)>,
    pub(super) bc: Vec<Vector<MODES>>,
    pub(super) xc: Vec<Vector<MODES>>,
}

impl<const B: usize> Transfer<B> {
    /// The aggregates T was made from: the column of each row's block, `NONE` for rows
    /// without one, and the number of aggregates.
    pub(super) fn aggregates(&self) -> (Vec<u32>, usize) {
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
pub(super) struct Level<const B: usize> {
    /// Block rows and stored blocks of the level's matrix.
    pub(super) rows: usize,
    pub(super) blocks: usize,
    /// 0/1 per DOF: constrained (fine) or dropped (coarse) DOFs are 0; P's rows there are zero.
    pub(super) mask: Vec<Vector<B>>,
    pub(super) dinv: Vec<Block<B, B>>,
    pub(super) bounds: (f64, f64),
    pub(super) eigen_start: Vec<Vector<B>>,
    pub(super) r: Vec<Vector<B>>,
    pub(super) d: Vec<Vector<B>>,
    pub(super) d_next: Vec<Vector<B>>,
    pub(super) partials: Vec<f64>,
    pub(super) degree: usize,
    pub(super) coarse: Coarse<B>,
}

impl<const B: usize> Level<B> {
    /// Set up a level on `a` and decide how it is coarsened; returns the next level's data.
    pub(super) fn build(
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
        let restriction = Restriction::new(&p.pattern, nc);
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
            restriction,
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
    pub(super) fn update_smoother(&mut self, a: &impl BlockRows<B, B>, params: &AmgParams) {
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
    pub(super) fn galerkin(
        &self,
        a: &impl BlockRows<B, B>,
        t: &mut Transfer<B>,
        a_c: &mut Bsr<MODES, MODES>,
        params: &AmgParams,
    ) {
        let omega = params.prolongator_damping / self.bounds.1;
        let (dinv, mask, tent, t32) = (&self.dinv, &self.mask, &t.tentative, &t.t32);
        let a_cols = &a.pattern().cols;
        // P's rows are computed in f64 and stored rounded to f32, block by block (no f64 copy of
        // P: it would stay in the resident set after the refresh). Each block sums A's row in
        // order, as a product into the whole row would. The products below read the rounded
        // blocks, so A_c is the Galerkin product of the P the cycle applies.
        for_each_row(&t.p.pattern, &mut t.p32, ROW_CHUNK, |i, cols, row| {
            let scale = Block::<B, B>::from_diagonal(&mask[i]);
            let left = scale * (-omega * dinv[i]);
            for (out, &c) in row.iter_mut().zip(cols) {
                let mut sum = Block::<B, MODES>::zeros();
                for k in a.row(i) {
                    let j = a_cols[k] as usize;
                    for kt in tent.row(j) {
                        if tent.pattern.cols[kt] == c {
                            sum += a.block(k) * t32[kt].cast::<f64>();
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
            |k| a.block(k),
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
    pub(super) fn refresh(
        &mut self,
        a: &impl BlockRows<B, B>,
        params: &AmgParams,
        rest: &mut [CoarseLevel],
    ) {
        self.update_smoother(a, params);
        let mut coarse = std::mem::replace(&mut self.coarse, Coarse::Smooth);
        if let Coarse::Transfer(t) = &mut coarse {
            let (next, below) = rest.split_first_mut().expect("a level below");
            let mut a_c = next.a.lend();
            self.galerkin(a, t, &mut a_c, params);
            next.a.store(a_c);
            next.level.refresh(&next.a, params, below);
        } else {
            coarse = coarsest(a, params);
        }
        self.coarse = coarse;
    }

    /// `x ≈ A⁻¹·b` by one V-cycle from x = 0.
    pub(super) fn cycle(
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
                let t = &mut **t;
                t.restriction.apply(&t.p.pattern, &t.p32, r, &mut t.bc);
                let (next, below) = rest.split_first_mut().expect("a level below");
                next.level.cycle(&next.a, &t.bc, &mut t.xc, below);
                multiply_add_f32(&t.p.pattern, &t.p32, &t.xc, x);
                chebyshev(a, dinv, *bounds, *degree, b, x, false, [r, d, d_next]);
            }
        }
    }

    /// Bytes this level holds, by kind.
    pub(super) fn memory(&self) -> LevelMemory {
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
                    + t.restriction.heap_bytes()
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

    pub(super) fn is_direct(&self) -> bool {
        matches!(&self.coarse, Coarse::Direct(_))
    }

    pub(super) fn describe(&self) -> LevelInfo {
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
pub(super) struct LevelMemory {
    pub(super) matrix: usize,
    pub(super) vectors: usize,
    pub(super) transfer: usize,
    pub(super) product: usize,
}

/// The coarsest level's solver: dense Cholesky when small enough and it factors, else smoothing.
pub(super) fn coarsest<const B: usize>(a: &impl BlockRows<B, B>, params: &AmgParams) -> Coarse<B> {
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
pub(super) fn pseudo_random(i: usize) -> f64 {
    let mut h = (i as u64).wrapping_add(0x9E37_79B9_7F4A_7C15);
    h = (h ^ (h >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    h = (h ^ (h >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    h ^= h >> 31;
    0.5 + (h >> 11) as f64 / (1u64 << 53) as f64
}
