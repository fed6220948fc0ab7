//! The per-level solvers of the cycle: the Chebyshev smoother on D⁻¹A (D the block diagonal of
//! A), its spectral bound by Lanczos, and the dense Cholesky of the coarsest level.

use nalgebra::{Cholesky, DMatrix, DVector, Dyn};
use rayon::prelude::*;

use super::bsr::{Block, BlockRows, ROW_CHUNK, Vector, dot};

/// The inverse of each diagonal block of A. A block that is not invertible (a node with no
/// stiffness) falls back to its inverted diagonal, zero where that is not positive.
pub(crate) fn inverse_diagonal<const B: usize>(
    a: &impl BlockRows<B, B>,
    out: &mut Vec<Block<B, B>>,
) {
    out.resize(a.rows(), Block::zeros());
    out.par_iter_mut()
        .enumerate()
        .with_min_len(ROW_CHUNK)
        .for_each(|(i, inv)| {
            let d = a.find(i, i).map_or(Block::zeros(), |k| a.block(k));
            *inv = d
                .cholesky()
                .map(|c| c.inverse())
                .filter(|m| m.iter().all(|x| x.is_finite()))
                .unwrap_or_else(|| {
                    Block::from_diagonal(&d.diagonal().map(|x| if x > 0.0 { 1.0 / x } else { 0.0 }))
                });
        });
}

/// An upper estimate of λ_max(D⁻¹A) by `steps` of Lanczos in the D inner product: the largest
/// Ritz value plus its residual bound |β_k·y_k|, which is above λ_max in practice (the Ritz
/// value alone is always below). `start` seeds the Krylov space (overwritten); the scratch
/// vectors are resized to the level.
pub(crate) fn lanczos_bound<const B: usize>(
    a: &impl BlockRows<B, B>,
    dinv: &[Block<B, B>],
    start: &mut [Vector<B>],
    steps: usize,
    scratch: [&mut Vec<Vector<B>>; 3],
    partials: &mut Vec<f64>,
) -> f64 {
    let n = a.rows();
    let [v_prev, u, w] = scratch;
    for s in [&mut *v_prev, &mut *u, &mut *w] {
        s.resize(n, Vector::zeros());
    }
    // v = start, normalised in the D norm: ‖v‖²_D = vᵀ·D·v, with D·v computed as A's diagonal
    // blocks times v.
    let d_norm = |v: &[Vector<B>], tmp: &mut Vec<Vector<B>>, partials: &mut Vec<f64>| {
        tmp.par_iter_mut()
            .enumerate()
            .with_min_len(ROW_CHUNK)
            .for_each(|(i, t)| {
                *t = a.find(i, i).map_or(Vector::zeros(), |k| a.block(k) * v[i]);
            });
        dot(v, tmp, partials).max(0.0).sqrt()
    };
    let norm = d_norm(start, u, partials);
    if norm == 0.0 || !norm.is_finite() {
        return 1.0;
    }
    start.par_iter_mut().for_each(|x| *x /= norm);
    let v = start;
    v_prev.iter_mut().for_each(|x| *x = Vector::zeros());
    let mut alpha = Vec::with_capacity(steps);
    let mut beta: Vec<f64> = Vec::with_capacity(steps);
    for j in 0..steps {
        a.multiply(v, u);
        let aj = dot(v, u, partials);
        let bj_prev = if j > 0 { beta[j - 1] } else { 0.0 };
        w.par_iter_mut()
            .enumerate()
            .with_min_len(ROW_CHUNK)
            .for_each(|(i, wi)| *wi = dinv[i] * u[i] - aj * v[i] - bj_prev * v_prev[i]);
        alpha.push(aj);
        let bj = d_norm(w, u, partials);
        beta.push(bj);
        // A tiny (or NaN) β means the Krylov space is exhausted.
        let exhausted = bj.is_nan() || bj <= 1e-12 * aj.abs();
        if exhausted || j + 1 == steps {
            break;
        }
        // v_prev ← v, v ← w/β.
        v_prev
            .par_iter_mut()
            .zip(v.par_iter_mut())
            .zip(w.par_iter())
            .with_min_len(ROW_CHUNK)
            .for_each(|((p, x), wi)| {
                *p = *x;
                *x = wi / bj;
            });
    }
    let k = alpha.len();
    let t = DMatrix::from_fn(k, k, |r, c| {
        if r == c {
            alpha[r]
        } else if r + 1 == c {
            beta[r]
        } else if c + 1 == r {
            beta[c]
        } else {
            0.0
        }
    });
    let eigen = t.symmetric_eigen();
    let (top, value) =
        eigen
            .eigenvalues
            .iter()
            .enumerate()
            .fold((0, f64::NEG_INFINITY), |best, (i, &l)| {
                if l > best.1 { (i, l) } else { best }
            });
    let residual = (beta[k - 1] * eigen.eigenvectors[(k - 1, top)]).abs();
    let bound = value + residual;
    if bound.is_finite() && bound > 0.0 {
        bound
    } else {
        1.0
    }
}

/// Chebyshev polynomial smoothing of `A·x = b` on D⁻¹A over the eigenvalue interval
/// `[lower, upper]` (Saad, Iterative Methods §12.3): `degree` steps of the three-term recurrence.
/// Its error propagator `I − p(D⁻¹A)·D⁻¹A` is A-self-adjoint, and a contraction when `upper` is
/// above λ_max, so the same smoother before and after the coarse correction keeps the cycle
/// symmetric positive definite. With `zero_start` x is taken as 0 (whatever it holds) and the
/// first product is skipped.
#[allow(clippy::too_many_arguments)]
pub(crate) fn chebyshev<const B: usize>(
    a: &impl BlockRows<B, B>,
    dinv: &[Block<B, B>],
    (lower, upper): (f64, f64),
    degree: usize,
    b: &[Vector<B>],
    x: &mut [Vector<B>],
    zero_start: bool,
    scratch: [&mut [Vector<B>]; 3],
) {
    let [r, d, d_next] = scratch;
    let theta = 0.5 * (upper + lower);
    let delta = 0.5 * (upper - lower);
    let sigma = theta / delta;
    // r = D⁻¹(b − A·x), d = r/θ, x += d.
    let x_in: &[Vector<B>] = x;
    r.par_iter_mut()
        .zip(d.par_iter_mut())
        .enumerate()
        .with_min_len(ROW_CHUNK)
        .for_each(|(i, (ri, di))| {
            let res = if zero_start {
                b[i]
            } else {
                b[i] - a.row_product(i, x_in)
            };
            *ri = dinv[i] * res;
            *di = *ri / theta;
        });
    x.par_iter_mut()
        .zip(d.par_iter())
        .with_min_len(ROW_CHUNK)
        .for_each(|(xi, di)| if zero_start { *xi = *di } else { *xi += di });
    let mut rho = 1.0 / sigma;
    let (mut d, mut d_next) = (d, d_next);
    for _ in 1..degree {
        let rho_next = 1.0 / (2.0 * sigma - rho);
        let (c_d, c_r) = (rho_next * rho, 2.0 * rho_next / delta);
        // One fused pass: r −= D⁻¹·A·d, d' = c_d·d + c_r·r, x += d'.
        let d_old: &[Vector<B>] = d;
        d_next
            .par_iter_mut()
            .zip(r.par_iter_mut())
            .zip(x.par_iter_mut())
            .enumerate()
            .with_min_len(ROW_CHUNK)
            .for_each(|(i, ((dn, ri), xi))| {
                *ri -= dinv[i] * a.row_product(i, d_old);
                *dn = c_d * d_old[i] + c_r * *ri;
                *xi += *dn;
            });
        std::mem::swap(&mut d, &mut d_next);
        rho = rho_next;
    }
}

/// The coarsest level's exact solve: a dense Cholesky factor of its matrix.
#[derive(Clone, Debug)]
pub(crate) struct Direct {
    factor: Option<Cholesky<f64, Dyn>>,
    rhs: DVector<f64>,
}

impl Direct {
    /// Bytes held: the dense factor and the right-hand side.
    pub fn heap_bytes(&self) -> usize {
        8 * (self.factor.as_ref().map_or(0, |f| f.l_dirty().len()) + self.rhs.len())
    }

    /// Factor A (exactly symmetric). If rounding made it indefinite, the diagonal is nudged up by
    /// 1e-12 of its largest entry until it factors (at most a few times).
    pub fn new<const B: usize>(a: &impl BlockRows<B, B>) -> Self {
        let n = B * a.rows();
        let mut dense = DMatrix::<f64>::zeros(n, n);
        for i in 0..a.rows() {
            for k in a.row(i) {
                let j = a.pattern().cols[k] as usize;
                dense
                    .view_mut((B * i, B * j), (B, B))
                    .copy_from(&a.block(k));
            }
        }
        let scale = dense.diagonal().amax();
        let mut factor = None;
        for attempt in 0..6 {
            let mut m = dense.clone();
            if attempt > 0 {
                let shift = scale * 1e-12 * 100f64.powi(attempt - 1);
                for i in 0..n {
                    m[(i, i)] += shift;
                }
            }
            if let Some(c) = Cholesky::new(m) {
                factor = Some(c);
                break;
            }
        }
        Direct {
            factor,
            rhs: DVector::zeros(n),
        }
    }

    /// `x = A⁻¹·b` (x = 0 if the factorisation failed; callers check [`Direct::is_factored`]).
    pub fn solve<const B: usize>(&mut self, b: &[Vector<B>], x: &mut [Vector<B>]) {
        let Some(factor) = &self.factor else {
            x.iter_mut().for_each(|v| *v = Vector::zeros());
            return;
        };
        for (i, v) in b.iter().enumerate() {
            for c in 0..B {
                self.rhs[B * i + c] = v[c];
            }
        }
        factor.solve_mut(&mut self.rhs);
        for (i, v) in x.iter_mut().enumerate() {
            for c in 0..B {
                v[c] = self.rhs[B * i + c];
            }
        }
    }

    /// Whether the factorisation succeeded.
    pub fn is_factored(&self) -> bool {
        self.factor.is_some()
    }
}
