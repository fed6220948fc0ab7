//! The lowest eigenpairs of `A·x = λ·B·x` (A symmetric positive semi-definite, B a positive
//! diagonal mass) by LOBPCG, knowing nothing of FEM: A is any [`LinearOperator`] on vertex
//! vectors, the preconditioner T ≈ A⁻¹ any [`Preconditioner`] (the multigrid V-cycle), B one
//! positive number per vertex acting on its three components, constrained DOFs a 0/1 mask.
//!
//! **Method** (Knyazev 2001, with the basis handling of Hetmaniuk and Lehoucq 2006 and Duersch
//! et al. 2018). A block X of m = `count + guard` B-orthonormal vectors is improved by
//! Rayleigh-Ritz on the subspace `S = [X, W, P]`, where `W = T·R` preconditions the residuals
//! `R = A·X − B·X·Λ` of the columns not yet converged and P holds the last step's change of
//! those columns (the "conjugate" directions). Each iteration:
//! 1. `[W, P]` is kept B-orthogonal to the deflated vectors Y (zero-frequency modes the caller
//!    knows) and to X (block Gram-Schmidt, done twice, which is enough in floating point), then
//!    B-orthonormalised by Cholesky-QR applied twice; when its Gram matrix is too ill-conditioned
//!    for Cholesky (a direction of P almost in the span of the others), by SVQB instead, which
//!    drops the dependent directions rather than amplifying rounding errors.
//! 2. Rayleigh-Ritz: `H = SᵀAS` and `G = SᵀBS` (G ≈ I, but its rounding is honoured: the small
//!    generalised problem `H·c = θ·G·c` is solved through the Cholesky factor of G and nalgebra's
//!    `SymmetricEigen`), the m smallest Ritz pairs become the new X, A·X and P are the same
//!    combinations of the basis (no extra products).
//!
//! Soft locking: converged columns take no part in W and P (so they cost no preconditioner
//! applications) but stay in X and in every Rayleigh-Ritz, so the wanted pairs stay mutually
//! orthogonal and a converged column keeps improving with the others; each iteration re-tests
//! every column, so one that drifts out of tolerance is iterated again. The guard columns beyond
//! `count` make the block larger than the wanted set: a repeated eigenvalue that straddles
//! `count` (the second of a bending pair) is then inside the block, and the convergence rate of
//! the last wanted pair depends on the gap to the first unwanted Ritz value rather than the next.
//!
//! **Convergence test.** A column (x, λ) with xᵀBx = 1 has converged when
//! `‖A·x − λ·B·x‖_{B⁻¹} ≤ tolerance·|λ| + floor`: the residual of the equivalent standard problem
//! `B^{-1/2}·A·B^{-1/2}`, so an eigenvalue lies within `tolerance·|λ| + floor` of λ (the frequency
//! √λ/2π within half that, relatively) and the error in λ is in fact of order residual²/gap.
//! `floor` is the rounding floor of the residual, `10·ε·λ̄` with λ̄ the caller's bound on the
//! largest eigenvalue (0 when unknown): near it no iteration can go further, and near-zero
//! eigenvalues (mechanisms of a mesh) are judged by it. The test runs on A·X kept as
//! combinations, and once all wanted columns pass, again on freshly computed products: only that
//! decides. An iteration that stops improving (a tolerance below what rounding allows) ends with
//! [`LobpcgError::NotConverged`] rather than running to the cap.
//!
//! **Determinism.** Start vectors come from a seeded generator, block products and inner
//! products run over fixed vertex chunks summed in order: the same bits on any thread count.

use std::time::Instant;

use nalgebra::{DMatrix, SymmetricEigen};
use rayon::prelude::*;

use super::cg::{LinearOperator, Preconditioner};
use crate::math::Vec3;

mod dense;
use dense::{
    combine, combine_slices, gram_slices, gram_sym, gram_sym_mass, gram_sym_slices, rayleigh_ritz,
};

/// Vertices per parallel chunk of the block kernels; fixed so that sums are deterministic.
const CHUNK: usize = 2048;

/// Rounding floor of the residual in units of ε·λ̄ (see the module docs). Measured on the
/// 192k-tet cantilever without a floor: fresh residuals went down to 1e-10·λ₁ and stalled there,
/// while 10·ε·λ̄ (Gershgorin's λ̄) is 5e-9·λ₁: the floor sits above what rounding allows.
const FLOOR_ULPS: f64 = 10.0;

/// The iteration gives up when the wanted columns' worst residual (relative to what the test
/// asks) has not improved by 10 % in this many iterations: the tolerance is then below what
/// rounding allows, and more iterations only burn time.
const STAGNATION_ITERATIONS: usize = 25;

/// Cholesky-QR is used while the Gram matrix's smallest pivot² over its largest stays above
/// this (κ(G) ≲ 1e12, so one pass leaves an orthogonality error of ~1e-4 that the second pass
/// removes); below it SVQB takes over.
const CHOLQR_MIN_PIVOT_RATIO: f64 = 1e-12;

/// SVQB drops directions whose Gram eigenvalue is below this fraction of the largest (after
/// scaling the columns to unit norm): they are rounding noise, not new directions.
const SVQB_DROP: f64 = 1e-12;

/// A block of vectors, column by column (each a vertex vector).
pub type Block = Vec<Vec<Vec3>>;

/// LOBPCG settings. The defaults suit the vibration modes of elastic bodies.
#[derive(Clone, Debug, PartialEq)]
pub struct LobpcgParams {
    /// Eigenpairs wanted (the smallest). Default 6.
    pub count: usize,
    /// Extra block columns beyond `count`, iterated but not reported (see the module docs).
    /// Default: None, meaning `max(4, count/2)` capped at 16: on the 41k-tet cantilever, 6
    /// modes took fewer iterations with 4 guards than with 2, and more guards cost more
    /// preconditioner applications per iteration than they saved.
    pub guard: Option<usize>,
    /// Relative residual of the convergence test. Default 1e-6 (frequencies then carry an
    /// error below 5e-7, in practice of order 1e-12).
    pub tolerance: f64,
    /// Iteration cap. Default 1000.
    pub max_iterations: usize,
    /// An upper bound on the largest eigenvalue of B⁻¹A, for the rounding floor of the
    /// convergence test (0: no floor). Default 0.
    pub spectrum_bound: f64,
    /// Seed of the start vectors. Default 1.
    pub seed: u64,
}

impl Default for LobpcgParams {
    fn default() -> Self {
        LobpcgParams {
            count: 6,
            guard: None,
            tolerance: 1e-6,
            max_iterations: 1000,
            spectrum_bound: 0.0,
            seed: 1,
        }
    }
}

impl LobpcgParams {
    /// The block size: `count` plus the guard columns, at most `dofs`.
    pub fn block_size(&self, dofs: usize) -> usize {
        let guard = self.guard.unwrap_or((self.count / 2).clamp(4, 16));
        (self.count + guard).min(dofs)
    }
}

/// What a LOBPCG run did.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LobpcgInfo {
    /// Iterations (Rayleigh-Ritz steps after the first).
    pub iterations: usize,
    /// Products with A (one per vector).
    pub operator_products: usize,
    /// Applications of the preconditioner (one per vector).
    pub preconditioner_applications: usize,
    /// Block size m (count + guard columns).
    pub block_size: usize,
    /// `‖A·x − λ·B·x‖_{B⁻¹} / |λ|` of each reported pair, from fresh products.
    pub relative_residuals: Vec<f64>,
    /// Whether every reported pair passed the convergence test.
    pub converged: bool,
    /// Directions SVQB dropped as dependent (0 when Cholesky-QR always sufficed).
    pub dropped_directions: usize,
    /// Seconds in products with A.
    pub operator_seconds: f64,
    /// Seconds in the preconditioner.
    pub preconditioner_seconds: f64,
    /// Seconds in all: the rest is the block work (orthogonalisation, Rayleigh-Ritz, updates).
    pub seconds: f64,
}

/// Eigenvalues (ascending) and B-orthonormal eigenvectors (`xᵢᵀ·B·xⱼ = δᵢⱼ`).
#[derive(Clone, Debug, Default)]
pub struct Eigenpairs {
    /// λ, ascending.
    pub values: Vec<f64>,
    /// The vectors, zero on constrained DOFs.
    pub vectors: Block,
    /// What it took.
    pub info: LobpcgInfo,
}

/// Why LOBPCG stopped without an answer.
#[derive(Clone, Debug, thiserror::Error)]
pub enum LobpcgError {
    /// More pairs asked for than the problem has DOFs (after deflation).
    #[error(
        "{wanted} eigenpairs asked for, but the problem has only {available} degrees of freedom"
    )]
    TooFewDofs {
        /// Pairs asked for.
        wanted: usize,
        /// Free DOFs minus deflated vectors.
        available: usize,
    },
    /// The iteration cap was reached; the best approximations so far are inside.
    #[error(
        "LOBPCG did not converge in {} iterations (largest relative residual {:.1e})",
        .0.info.iterations,
        .0.info.relative_residuals.iter().fold(0.0_f64, |a, &b| a.max(b))
    )]
    NotConverged(Box<Eigenpairs>),
    /// A NaN or infinity appeared (a non-finite operator or preconditioner).
    #[error("LOBPCG produced a non-finite value at iteration {iteration}")]
    NonFinite {
        /// The iteration.
        iteration: usize,
    },
}

/// The `count` smallest eigenpairs of `A·x = λ·B·x` on the free DOFs (`free`: 0/1 per
/// component), B = `mass[v]` on each component of vertex v (positive where free), kept
/// B-orthogonal to the vectors of `deflate` (known eigenvectors, e.g. rigid-body modes;
/// orthonormalised here). See the module docs.
pub fn lobpcg(
    a: &mut dyn LinearOperator,
    mass: &[f64],
    free: &[Vec3],
    t: &mut dyn Preconditioner,
    deflate: &[Vec<Vec3>],
    params: &LobpcgParams,
) -> Result<Eigenpairs, LobpcgError> {
    let started = Instant::now();
    let n = mass.len();
    assert_eq!(free.len(), n);
    assert_eq!(a.len(), n);
    let mut run = Run {
        a,
        t,
        mass,
        inverse_mass: mass
            .iter()
            .map(|&m| if m > 0.0 { 1.0 / m } else { 0.0 })
            .collect(),
        free,
        info: LobpcgInfo::default(),
    };
    let mut y: Block = deflate.iter().map(|v| run.masked(v)).collect();
    run.orthonormalize(&mut y);
    // Only the iteration's own drops are reported.
    run.info.dropped_directions = 0;
    let dofs = free.iter().map(|m| m.sum() as usize).sum::<usize>();
    let available = dofs.saturating_sub(y.len());
    if params.count > available {
        return Err(LobpcgError::TooFewDofs {
            wanted: params.count,
            available,
        });
    }
    if params.count == 0 {
        return Ok(Eigenpairs::default());
    }
    let m = params.block_size(available);
    run.info.block_size = m;
    let floor = FLOOR_ULPS * f64::EPSILON * params.spectrum_bound;

    // Start: random vectors, deflated, orthonormalised, one Rayleigh-Ritz.
    let mut x: Block = (0..m).map(|j| run.random(params.seed, j)).collect();
    run.deflate(&mut x, &y);
    run.orthonormalize(&mut x);
    if x.len() < m {
        // Only possible when the free space is barely larger than the block.
        return Err(LobpcgError::TooFewDofs {
            wanted: m,
            available: x.len(),
        });
    }
    let mut ax = run.apply_all(&x);
    let (mut lambda, c) = rayleigh_ritz(&gram_sym(&x, &ax), &gram_sym_mass(&x, mass), m)
        .ok_or(LobpcgError::NonFinite { iteration: 0 })?;
    x = combine(&[&x], &c);
    ax = combine(&[&ax], &c);
    let mut p: Block = Vec::new();
    let mut fresh = true;
    let mut iteration = 0;
    let (mut best, mut best_at) = (f64::INFINITY, 0);
    loop {
        let r = run.residuals(&x, &ax, &lambda);
        let norms: Vec<f64> = r.iter().map(|r| run.inverse_mass_norm(r)).collect();
        if norms.iter().chain(&lambda).any(|v| !v.is_finite()) {
            return Err(LobpcgError::NonFinite { iteration });
        }
        let converged: Vec<bool> = norms
            .iter()
            .zip(&lambda)
            .map(|(r, l)| *r <= params.tolerance * l.abs() + floor)
            .collect();
        let wanted_done = converged[..params.count].iter().all(|&c| c);
        log::debug!(
            "LOBPCG iteration {iteration}: {} of {m} columns converged, largest relative residual of the wanted {:.2e}",
            converged.iter().filter(|&&c| c).count(),
            norms[..params.count]
                .iter()
                .zip(&lambda)
                .map(|(r, l)| r / l.abs().max(f64::MIN_POSITIVE))
                .fold(0.0, f64::max)
        );
        if wanted_done && !fresh {
            // Judge on fresh products, not on combinations that carry rounding from every step.
            ax = run.apply_all(&x);
            fresh = true;
            continue;
        }
        let worst = norms[..params.count]
            .iter()
            .zip(&lambda)
            .map(|(r, l)| r / (params.tolerance * l.abs() + floor).max(f64::MIN_POSITIVE))
            .fold(0.0, f64::max);
        if worst < 0.9 * best {
            (best, best_at) = (worst, iteration);
        }
        let stagnated = iteration >= best_at + STAGNATION_ITERATIONS;
        if stagnated {
            log::debug!(
                "LOBPCG iteration {iteration}: no progress in {STAGNATION_ITERATIONS} iterations"
            );
        }
        if wanted_done || stagnated || iteration >= params.max_iterations {
            run.info.iterations = iteration;
            run.info.relative_residuals = norms[..params.count]
                .iter()
                .zip(&lambda)
                .map(|(r, l)| r / l.abs().max(f64::MIN_POSITIVE))
                .collect();
            run.info.converged = wanted_done;
            run.info.seconds = started.elapsed().as_secs_f64();
            x.truncate(params.count);
            lambda.truncate(params.count);
            let pairs = Eigenpairs {
                values: lambda,
                vectors: x,
                info: run.info,
            };
            return if pairs.info.converged {
                Ok(pairs)
            } else {
                Err(LobpcgError::NotConverged(Box::new(pairs)))
            };
        }
        iteration += 1;
        fresh = false;
        let active: Vec<usize> = (0..m).filter(|&j| !converged[j]).collect();
        let mut q: Block = active.iter().map(|&j| run.precondition(&r[j])).collect();
        if !p.is_empty() {
            q.extend(active.iter().map(|&j| std::mem::take(&mut p[j])));
        }
        drop(r);
        run.deflate(&mut q, &y);
        for _ in 0..2 {
            run.project_out(&mut q, &x);
        }
        run.orthonormalize(&mut q);
        let aq = run.apply_all(&q);
        let s: Vec<&[Vec3]> = x.iter().chain(&q).map(Vec::as_slice).collect();
        let as_: Vec<&[Vec3]> = ax.iter().chain(&aq).map(Vec::as_slice).collect();
        let h = gram_sym_slices(&s, &as_, None);
        let g = gram_sym_slices(&s, &s, Some(mass));
        let Some((values, c)) = rayleigh_ritz(&h, &g, m) else {
            // G not positive definite: the basis lost its orthonormality. Restart from X
            // alone (drop P), which the next iteration rebuilds.
            log::debug!("LOBPCG iteration {iteration}: restart without P");
            p.clear();
            continue;
        };
        lambda = values;
        let new_x = combine_slices(&s, &c);
        let new_ax = combine_slices(&as_, &c);
        p = if q.is_empty() {
            Vec::new()
        } else {
            combine(&[&q], &c.rows(m, q.len()).into_owned())
        };
        x = new_x;
        ax = new_ax;
    }
}

/// The operator, preconditioner and mass of one run, with its counts.
struct Run<'a> {
    a: &'a mut dyn LinearOperator,
    t: &'a mut dyn Preconditioner,
    mass: &'a [f64],
    inverse_mass: Vec<f64>,
    free: &'a [Vec3],
    info: LobpcgInfo,
}

impl Run<'_> {
    fn masked(&self, v: &[Vec3]) -> Vec<Vec3> {
        v.iter()
            .zip(self.free)
            .map(|(v, m)| v.component_mul(m))
            .collect()
    }

    /// A start vector: uniform in [−1, 1] per free component, from (seed, column, vertex).
    fn random(&self, seed: u64, column: usize) -> Vec<Vec3> {
        let base = splitmix(seed ^ splitmix(column as u64 + 1));
        (0..self.mass.len())
            .map(|v| {
                let mut s = splitmix(base ^ (v as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15));
                let mut next = || {
                    s = splitmix(s);
                    (s >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
                };
                Vec3::new(next(), next(), next()).component_mul(&self.free[v])
            })
            .collect()
    }

    /// A·v, masked.
    fn apply(&mut self, v: &[Vec3]) -> Vec<Vec3> {
        let started = Instant::now();
        let mut out = vec![Vec3::zeros(); v.len()];
        self.a.apply(v, &mut out);
        self.info.operator_seconds += started.elapsed().as_secs_f64();
        self.info.operator_products += 1;
        mask(&mut out, self.free);
        out
    }

    fn apply_all(&mut self, block: &Block) -> Block {
        block.iter().map(|v| self.apply(v)).collect()
    }

    /// T·r, masked.
    fn precondition(&mut self, r: &[Vec3]) -> Vec<Vec3> {
        let started = Instant::now();
        let mut out = vec![Vec3::zeros(); r.len()];
        self.t.apply(r, &mut out);
        self.info.preconditioner_seconds += started.elapsed().as_secs_f64();
        self.info.preconditioner_applications += 1;
        mask(&mut out, self.free);
        out
    }

    /// `R = A·X − B·X·Λ`, column by column.
    fn residuals(&self, x: &Block, ax: &Block, lambda: &[f64]) -> Block {
        residuals(x, ax, lambda, self.mass)
    }

    /// `‖r‖_{B⁻¹}` over the free DOFs (r is zero elsewhere).
    fn inverse_mass_norm(&self, r: &[Vec3]) -> f64 {
        gram_sym_slices(&[r], &[r], Some(&self.inverse_mass))[(0, 0)]
            .max(0.0)
            .sqrt()
    }

    /// `Q ← Q − Y·(YᵀBQ)` twice (Y B-orthonormal).
    fn deflate(&self, q: &mut Block, y: &Block) {
        if y.is_empty() {
            return;
        }
        for _ in 0..2 {
            self.project_out(q, y);
        }
    }

    /// `Q ← Q − X·(XᵀBQ)` (X B-orthonormal), once.
    fn project_out(&self, q: &mut Block, x: &Block) {
        if q.is_empty() || x.is_empty() {
            return;
        }
        let xs: Vec<&[Vec3]> = x.iter().map(Vec::as_slice).collect();
        let qs: Vec<&[Vec3]> = q.iter().map(Vec::as_slice).collect();
        let coefficients = gram_slices(&xs, &qs, Some(self.mass));
        let correction = combine_slices(&xs, &coefficients);
        q.par_iter_mut().zip(correction).for_each(|(q, c)| {
            q.iter_mut().zip(c).for_each(|(q, c)| *q -= c);
        });
    }

    /// B-orthonormalise the columns of `q` in place: Cholesky-QR twice, or SVQB (dropping
    /// dependent directions) when the Gram matrix is too ill-conditioned; returns how many
    /// columns were dropped.
    fn orthonormalize(&mut self, q: &mut Block) -> usize {
        let before = q.len();
        if q.is_empty() {
            return 0;
        }
        if !self.cholesky_qr(q) {
            self.svqb(q);
            // One Cholesky-QR pass after SVQB polishes the orthogonality.
            if !q.is_empty() && !self.cholesky_qr(q) {
                self.svqb(q);
            }
        } else {
            self.cholesky_qr(q);
        }
        let dropped = before - q.len();
        self.info.dropped_directions += dropped;
        dropped
    }

    /// One Cholesky-QR pass: `Q ← Q·L⁻ᵀ` with `QᵀBQ = L·Lᵀ`; false (Q unchanged) when the
    /// factor fails or is too ill-conditioned.
    fn cholesky_qr(&self, q: &mut Block) -> bool {
        let g = gram_sym_mass(q, self.mass);
        let Some(chol) = g.clone().cholesky() else {
            return false;
        };
        let l = chol.l();
        let pivots: Vec<f64> = l.diagonal().iter().map(|d| d * d).collect();
        let largest = pivots.iter().copied().fold(0.0, f64::max);
        let smallest = pivots.iter().copied().fold(f64::INFINITY, f64::min);
        if smallest.is_nan() || smallest <= CHOLQR_MIN_PIVOT_RATIO * largest || !largest.is_finite()
        {
            return false;
        }
        let Some(l_inv) = l.try_inverse() else {
            return false;
        };
        *q = combine(&[&*q], &l_inv.transpose());
        true
    }

    /// SVQB (Stathopoulos and Wu 2002): scale columns to unit B-norm, `Q ← Q·D·V·Θ^{-1/2}` over
    /// the eigenpairs (θ, v) of the scaled Gram matrix with θ above [`SVQB_DROP`]·θ_max.
    fn svqb(&self, q: &mut Block) {
        let g = gram_sym_mass(q, self.mass);
        let k = g.nrows();
        let d: Vec<f64> = (0..k)
            .map(|i| {
                let gi = g[(i, i)];
                if gi > 0.0 && gi.is_finite() {
                    1.0 / gi.sqrt()
                } else {
                    0.0
                }
            })
            .collect();
        let scaled = DMatrix::from_fn(k, k, |i, j| d[i] * g[(i, j)] * d[j]);
        let eigen = SymmetricEigen::new(scaled);
        let top = eigen.eigenvalues.iter().copied().fold(0.0, f64::max);
        let mut order: Vec<usize> = (0..k)
            .filter(|&i| eigen.eigenvalues[i] > SVQB_DROP * top)
            .collect();
        order.sort_by(|&i, &j| eigen.eigenvalues[j].total_cmp(&eigen.eigenvalues[i]));
        let c = DMatrix::from_fn(k, order.len(), |i, c| {
            let e = order[c];
            d[i] * eigen.eigenvectors[(i, e)] / eigen.eigenvalues[e].sqrt()
        });
        *q = combine(&[&*q], &c);
    }
}

/// `R = A·X − B·X·Λ`, column by column.
fn residuals(x: &Block, ax: &Block, lambda: &[f64], mass: &[f64]) -> Block {
    x.par_iter()
        .zip(ax)
        .zip(lambda)
        .map(|((x, ax), &l)| {
            ax.iter()
                .zip(x)
                .zip(mass)
                .map(|((ax, x), m)| ax - x * (l * m))
                .collect()
        })
        .collect()
}

fn mask(v: &mut [Vec3], free: &[Vec3]) {
    v.par_iter_mut()
        .zip(free)
        .with_min_len(CHUNK)
        .for_each(|(v, m)| *v = v.component_mul(m));
}

/// splitmix64: a small, well-mixed generator for reproducible start vectors.
fn splitmix(x: u64) -> u64 {
    let mut z = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

#[cfg(test)]
mod tests {
    //! LOBPCG on problems whose spectrum is known in closed form.

    use super::*;

    /// A chain of `n` unit masses on springs of stiffness k, fixed at both ends, moving in all
    /// three directions alike: every eigenvalue appears three times, `λ_j = 4k·sin²(jπ/(2(n+1)))`.
    struct Chain {
        n: usize,
        k: f64,
    }

    impl LinearOperator for Chain {
        fn len(&self) -> usize {
            self.n
        }

        fn apply(&mut self, p: &[Vec3], out: &mut [Vec3]) {
            for i in 0..self.n {
                let left = if i > 0 { p[i - 1] } else { Vec3::zeros() };
                let right = if i + 1 < self.n {
                    p[i + 1]
                } else {
                    Vec3::zeros()
                };
                out[i] = self.k * (2.0 * p[i] - left - right);
            }
        }
    }

    /// Jacobi on the chain: a weak preconditioner, so the iteration has work to do.
    struct Diagonal(f64);

    impl Preconditioner for Diagonal {
        fn apply(&mut self, r: &[Vec3], z: &mut [Vec3]) {
            z.iter_mut().zip(r).for_each(|(z, r)| *z = r / self.0);
        }
    }

    #[test]
    fn triple_eigenvalues_of_a_chain_all_come_out() {
        let (n, k) = (40, 3.0);
        let mass = vec![1.0; n];
        let free = vec![Vec3::repeat(1.0); n];
        let params = LobpcgParams {
            count: 7,
            tolerance: 1e-9,
            ..Default::default()
        };
        let pairs = lobpcg(
            &mut Chain { n, k },
            &mass,
            &free,
            &mut Diagonal(2.0 * k),
            &[],
            &params,
        )
        .unwrap();
        // λ₁ three times, λ₂ three times, then λ₃.
        let exact = |j: usize| {
            4.0 * k
                * (j as f64 * std::f64::consts::PI / (2.0 * (n as f64 + 1.0)))
                    .sin()
                    .powi(2)
        };
        let expected = [1, 1, 1, 2, 2, 2, 3].map(exact);
        for (got, want) in pairs.values.iter().zip(expected) {
            assert!((got - want).abs() <= 1e-9 * want, "{got} vs {want}");
        }
        // B-orthonormal.
        let g = gram_sym_mass(&pairs.vectors, &mass);
        assert!((g - DMatrix::identity(7, 7)).amax() < 1e-10);
        assert!(pairs.info.converged && pairs.info.iterations > 0);
    }

    #[test]
    fn deflated_vectors_are_skipped_and_masses_weigh_in() {
        // Free chain (no walls): the constant vector per component is the zero mode; deflated,
        // the smallest are the first nonzero modes. Masses 2 halve every eigenvalue.
        struct FreeChain(usize);
        impl LinearOperator for FreeChain {
            fn len(&self) -> usize {
                self.0
            }
            fn apply(&mut self, p: &[Vec3], out: &mut [Vec3]) {
                let n = self.0;
                for i in 0..n {
                    let mut s = Vec3::zeros();
                    if i > 0 {
                        s += p[i] - p[i - 1];
                    }
                    if i + 1 < n {
                        s += p[i] - p[i + 1];
                    }
                    out[i] = s;
                }
            }
        }
        struct Shifted;
        impl Preconditioner for Shifted {
            fn apply(&mut self, r: &[Vec3], z: &mut [Vec3]) {
                z.copy_from_slice(r);
            }
        }
        let n = 30;
        let mass = vec![2.0; n];
        let free = vec![Vec3::repeat(1.0); n];
        let constant: Vec<Vec<Vec3>> = (0..3).map(|k| vec![Vec3::ith(k, 1.0); n]).collect();
        let pairs = lobpcg(
            &mut FreeChain(n),
            &mass,
            &free,
            &mut Shifted,
            &constant,
            &LobpcgParams {
                count: 3,
                tolerance: 1e-9,
                ..Default::default()
            },
        )
        .unwrap();
        // Free-free chain: λ_j = 4 sin²(jπ/(2n)) / mass.
        let want = 4.0 * (std::f64::consts::PI / (2.0 * n as f64)).sin().powi(2) / 2.0;
        for got in &pairs.values {
            assert!((got - want).abs() <= 1e-9 * want, "{got} vs {want}");
        }
        for v in &pairs.vectors {
            let sum: Vec3 = v.iter().sum();
            assert!(sum.norm() < 1e-9, "not orthogonal to the deflated modes");
        }
    }

    #[test]
    fn an_unreachable_tolerance_stops_early_with_the_best_pairs() {
        // 1e-20 is below rounding: the iteration must notice it stopped improving and say so,
        // not run to the cap.
        let (n, k) = (40, 3.0);
        let err = lobpcg(
            &mut Chain { n, k },
            &vec![1.0; n],
            &vec![Vec3::repeat(1.0); n],
            &mut Diagonal(2.0 * k),
            &[],
            &LobpcgParams {
                count: 2,
                tolerance: 1e-20,
                ..Default::default()
            },
        )
        .unwrap_err();
        let LobpcgError::NotConverged(pairs) = err else {
            panic!("{err}");
        };
        assert!(pairs.info.iterations < 200, "{:?}", pairs.info);
        // What it has is still right to rounding.
        let exact = 4.0
            * k
            * (std::f64::consts::PI / (2.0 * (n as f64 + 1.0)))
                .sin()
                .powi(2);
        assert!((pairs.values[0] - exact).abs() < 1e-12 * exact);
    }

    #[test]
    fn too_many_pairs_for_the_free_dofs_is_an_error() {
        let n = 3;
        let mut free = vec![Vec3::zeros(); n];
        free[1] = Vec3::repeat(1.0);
        let err = lobpcg(
            &mut Chain { n, k: 1.0 },
            &[1.0; 3],
            &free,
            &mut Diagonal(2.0),
            &[],
            &LobpcgParams {
                count: 4,
                ..Default::default()
            },
        )
        .unwrap_err();
        assert!(matches!(
            err,
            LobpcgError::TooFewDofs {
                wanted: 4,
                available: 3
            }
        ));
    }
}
