//! Test helpers for the contact module: seeded randomness and finite differences with a sweep of
//! step sizes (trust the best step, not one ε).

use nalgebra::{SMatrix, SVector};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::math::Vec3;

/// A seeded generator, so every failure reproduces.
pub fn rng(seed: u64) -> ChaCha8Rng {
    ChaCha8Rng::seed_from_u64(seed)
}

/// Uniform in [lo, hi).
pub fn uniform(rng: &mut ChaCha8Rng, lo: f64, hi: f64) -> f64 {
    rng.random_range(lo..hi)
}

/// A point with coordinates uniform in [−1, 1).
pub fn point(rng: &mut ChaCha8Rng) -> Vec3 {
    Vec3::new(
        uniform(rng, -1.0, 1.0),
        uniform(rng, -1.0, 1.0),
        uniform(rng, -1.0, 1.0),
    )
}

/// Step sizes swept by the finite-difference checks.
pub const STEPS: [f64; 6] = [1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8];

/// Stack points into one dof vector.
pub fn stack<const N: usize>(x: &[Vec3]) -> SVector<f64, N> {
    SVector::<f64, N>::from_fn(|i, _| x[i / 3][i % 3])
}

/// Unstack a dof vector into points.
pub fn unstack<const N: usize>(v: &SVector<f64, N>) -> Vec<Vec3> {
    (0..N / 3)
        .map(|i| Vec3::new(v[3 * i], v[3 * i + 1], v[3 * i + 2]))
        .collect()
}

/// Best relative error (over [`STEPS`]) between `grad` and central differences of `f` at `x`.
/// Relative to the larger norm, floored by `floor` for gradients that should vanish.
pub fn fd_gradient_error<const N: usize>(
    f: impl Fn(&SVector<f64, N>) -> f64,
    x: &SVector<f64, N>,
    grad: &SVector<f64, N>,
    floor: f64,
) -> f64 {
    STEPS
        .iter()
        .map(|&h| {
            let mut fd = SVector::<f64, N>::zeros();
            for i in 0..N {
                let mut xp = *x;
                let mut xm = *x;
                xp[i] += h;
                xm[i] -= h;
                fd[i] = (f(&xp) - f(&xm)) / (2.0 * h);
            }
            (fd - grad).norm() / fd.norm().max(grad.norm()).max(floor)
        })
        .fold(f64::INFINITY, f64::min)
}

/// Best relative error between `hess` and central differences of `g` (the gradient) at `x`.
pub fn fd_hessian_error<const N: usize>(
    g: impl Fn(&SVector<f64, N>) -> SVector<f64, N>,
    x: &SVector<f64, N>,
    hess: &SMatrix<f64, N, N>,
    floor: f64,
) -> f64 {
    STEPS
        .iter()
        .map(|&h| {
            let mut fd = SMatrix::<f64, N, N>::zeros();
            for i in 0..N {
                let mut xp = *x;
                let mut xm = *x;
                xp[i] += h;
                xm[i] -= h;
                fd.set_column(i, &((g(&xp) - g(&xm)) / (2.0 * h)));
            }
            (fd - hess).norm() / fd.norm().max(hess.norm()).max(floor)
        })
        .fold(f64::INFINITY, f64::min)
}
