//! The SVD of [`LANES`] matrices at once, bit for bit the scalar [`svd_rv`](super::svd_rv).
//!
//! Why: a Jacobi rotation is a dependent chain of div, sqrt, div, sqrt (≈ 60–80 cycles of
//! latency for a few dozen flops), and one 3×3 eigen-solve is ~8 such rotations in a row, so the
//! scalar solver waits on latency, not arithmetic. Here four matrices go through their sweeps in
//! lock-step, one `wide::f64x4` lane each (two packed SSE2 registers on the default x86-64
//! target), and so do the Givens rotations of their QRs. Each lane does exactly the scalar
//! code's IEEE operations in the same order: a lane that has converged is frozen by a mask (its
//! sweep test is the scalar one), and a rotation the scalar code skips (a zero off-diagonal
//! entry, a zero column) is computed but blended away, so every lane's result has the scalar
//! result's bits. The group runs as many sweeps as its slowest lane (2.65 sweeps per solve on
//! average on the bench beam, 3–5 at most).
//!
//! Why `wide` (already in the tree through nalgebra) rather than plain `[f64; 4]` arrays: LLVM
//! left the arrays version scalar (divsd, sqrtsd, a branch per lane), 0.61–0.68 of the scalar
//! time per SVD against 0.50–0.55 with `wide` under the same load; eight lanes measured within
//! noise of four. `cargo run --release --example svd_batch` measures it (docs/performance.md).

// Rows p and r of small fixed arrays are indexed together: clearer than iterators.
#![allow(clippy::needless_range_loop)]

use wide::f64x4;

use super::{
    GIVENS, MAX_SWEEPS, Mat3, PLANES, Svd, Vec3, align_null_pair, jacobi_start, sort_descending,
};

/// How many matrices [`svd_rv_lanes`] decomposes together.
pub const LANES: usize = 4;

/// [`sym_eigen3`](super::sym_eigen3) of [`LANES`] symmetric matrices, with the same bits.
pub fn sym_eigen3_lanes(a: &[Mat3; LANES]) -> [(Vec3, Mat3); LANES] {
    let mut out = [(Vec3::zeros(), Mat3::zeros()); LANES];
    for (o, (lambda, q)) in out.iter_mut().zip(jacobi_lanes(a)) {
        *o = sort_descending(lambda, q);
    }
    out
}

/// The Jacobi sweeps of [`sym_eigen3_lanes`], before sorting: each lane's eigenvalues and
/// eigenvectors (columns) as the sweeps leave them.
#[inline(always)]
fn jacobi_lanes(a: &[Mat3; LANES]) -> [(Vec3, Mat3); LANES] {
    let (mut d, mut off) = ([[0.0; LANES]; 3], [[0.0; LANES]; 3]);
    let (mut tolerance, mut rotating) = ([0.0; LANES], [0.0; LANES]);
    for l in 0..LANES {
        let (dl, ol, tol) = jacobi_start(&a[l]);
        for i in 0..3 {
            d[i][l] = dl[i];
            off[i][l] = ol[i];
        }
        if let Some(tol) = tol {
            (tolerance[l], rotating[l]) = (tol, 1.0);
        }
    }
    let (zero, one) = (f64x4::ZERO, f64x4::ONE);
    let (mut d, mut off) = (d.map(f64x4::new), off.map(f64x4::new));
    let tolerance = f64x4::new(tolerance);
    // The lanes still rotating (all bits set) and those frozen (zero).
    let mut active = f64x4::new(rotating).simd_ne(zero);
    // q[row][col], the identity.
    let mut q = [[zero; 3]; 3];
    for (i, row) in q.iter_mut().enumerate() {
        row[i] = one;
    }
    for _ in 0..MAX_SWEEPS {
        let sum = off[0].abs() + off[1].abs() + off[2].abs();
        active = sum.simd_le(tolerance).select(zero, active);
        if !active.any() {
            break;
        }
        for (p, r, pr, pk, rk) in PLANES {
            let apr = off[pr];
            let go = active & apr.simd_ne(zero);
            // `jacobi_rotation` in lanes, op for op (signum by its sign bit).
            let theta = (d[r] - d[p]) / (f64x4::splat(2.0) * apr);
            let signum = one | (theta & f64x4::splat(-0.0));
            let t = theta
                .is_finite()
                .select(signum / (theta.abs() + (theta * theta + one).sqrt()), zero);
            let c = one / (t * t + one).sqrt();
            let s = t * c;
            d[p] = go.select(d[p] - t * apr, d[p]);
            d[r] = go.select(d[r] + t * apr, d[r]);
            off[pr] = go.select(zero, apr);
            let (apk, ark) = (off[pk], off[rk]);
            off[pk] = go.select(c * apk - s * ark, apk);
            off[rk] = go.select(s * apk + c * ark, ark);
            for row in q.iter_mut() {
                let (qp, qr) = (row[p], row[r]);
                row[p] = go.select(c * qp - s * qr, qp);
                row[r] = go.select(s * qp + c * qr, qr);
            }
        }
    }
    let d = d.map(f64x4::to_array);
    let q = q.map(|row| row.map(f64x4::to_array));
    let mut out = [(Vec3::zeros(), Mat3::zeros()); LANES];
    for (l, (lambda, v)) in out.iter_mut().enumerate() {
        *lambda = Vec3::new(d[0][l], d[1][l], d[2][l]);
        for i in 0..3 {
            for j in 0..3 {
                v[(i, j)] = q[i][j][l];
            }
        }
    }
    out
}

/// [`svd_rv`](super::svd_rv) of [`LANES`] matrices, with the same bits: the eigen-solves of
/// FᵀF in lock-step, then the Givens QRs of F·V in lock-step.
pub fn svd_rv_lanes(f: &[Mat3; LANES]) -> [Svd; LANES] {
    let mut out = [Svd {
        u: Mat3::zeros(),
        sigma: Vec3::zeros(),
        v: Mat3::zeros(),
    }; LANES];
    svd_rv_lanes_into(f, &mut out);
    out
}

/// [`svd_rv_lanes`] into `out` (the element loops keep one buffer: returning four SVDs, 672
/// bytes, by value cost the evaluation a sixth of its time in copies).
#[inline]
pub fn svd_rv_lanes_into(f: &[Mat3; LANES], out: &mut [Svd; LANES]) {
    let mut gram = [Mat3::zeros(); LANES];
    for (g, f) in gram.iter_mut().zip(f) {
        *g = f.transpose() * f;
    }
    for (o, (lambda, q)) in out.iter_mut().zip(jacobi_lanes(&gram)) {
        (o.sigma, o.v) = sort_descending(lambda, q);
    }
    qr_lanes(f, out);
}

/// [`svd_from_v`](super::svd_from_v) in lanes, V read from `out` and U and σ written there:
/// each Givens rotation (a sqrt and two divisions) of the four QRs together, a rotation the
/// scalar code skips (h = 0) blended away.
#[inline(always)]
fn qr_lanes(f: &[Mat3; LANES], out: &mut [Svd; LANES]) {
    let zero = f64x4::ZERO;
    // b[row][col] = F·V, ut[row][col] accumulates Qᵀ = G₃G₂G₁ from the identity.
    let mut fv = [[[0.0; LANES]; 3]; 3];
    for l in 0..LANES {
        let m = f[l] * out[l].v;
        for i in 0..3 {
            for j in 0..3 {
                fv[i][j][l] = m[(i, j)];
            }
        }
    }
    let mut b = fv.map(|row| row.map(f64x4::new));
    let mut ut = [[zero; 3]; 3];
    for (i, row) in ut.iter_mut().enumerate() {
        row[i] = f64x4::ONE;
    }
    for (col, p, r) in GIVENS {
        let (x, y) = (b[p][col], b[r][col]);
        let h = (x * x + y * y).sqrt();
        let go = h.simd_ne(zero);
        let (c, s) = (x / h, y / h);
        for m in [&mut b, &mut ut] {
            for k in 0..3 {
                let (mp, mr) = (m[p][k], m[r][k]);
                m[p][k] = go.select(c * mp + s * mr, mp);
                m[r][k] = go.select(-s * mp + c * mr, mr);
            }
        }
        b[r][col] = go.select(zero, b[r][col]);
    }
    let b = b.map(|row| row.map(f64x4::to_array));
    let ut = ut.map(|row| row.map(f64x4::to_array));
    for (l, o) in out.iter_mut().enumerate() {
        o.sigma = Vec3::new(b[0][0][l], b[1][1][l], b[2][2][l]);
        for i in 0..3 {
            for j in 0..3 {
                o.u[(i, j)] = ut[j][i][l];
            }
        }
        align_null_pair(&mut o.u, &o.v, &o.sigma);
    }
}

#[cfg(test)]
mod tests {
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    use super::super::{svd_rv, sym_eigen3};
    use super::*;

    /// Random F of every kind the solver meets: generic, near-rotations, inverted, rank-deficient,
    /// repeated singular values, zero, and lanes mixing them (so lanes converge at different
    /// sweeps).
    fn cases() -> Vec<Mat3> {
        let mut rng = ChaCha8Rng::seed_from_u64(4242);
        let mut next = move || rng.random_range(-1.0..1.0);
        let mut out = Vec::new();
        for k in 0..4000 {
            let m = Mat3::from_fn(|_, _| next());
            let r = nalgebra::Rotation3::from_scaled_axis(Vec3::new(next(), next(), next()) * 3.0)
                .into_inner();
            out.push(match k % 8 {
                0 | 1 => 2.0 * m,
                2 => r + 1e-3 * m,
                3 => r * Mat3::from_diagonal(&Vec3::new(1.0, 1.0, -0.2 + 0.1 * next())),
                4 => r * Mat3::from_diagonal(&Vec3::new(1.5, 1.5, 0.0)),
                5 => Vec3::new(next(), next(), next()) * Vec3::new(next(), 1.0, next()).transpose(),
                6 if k % 3 == 0 => Mat3::zeros(),
                6 => Mat3::identity(),
                _ => r * Mat3::from_diagonal(&Vec3::new(1.0 + next(), 1.0, 1.0)) * r.transpose(),
            });
        }
        out
    }

    #[test]
    fn lanes_give_the_scalar_bits() {
        for group in cases().chunks_exact(LANES) {
            let f: [Mat3; LANES] = group.try_into().unwrap();
            let batch = svd_rv_lanes(&f);
            for l in 0..LANES {
                let one = svd_rv(&f[l]);
                // Compare bits, not values: -0.0 and +0.0 must match too.
                let bits = |s: &Svd| {
                    s.u.iter()
                        .chain(s.sigma.iter())
                        .chain(s.v.iter())
                        .map(|x| x.to_bits())
                        .collect::<Vec<_>>()
                };
                assert_eq!(bits(&batch[l]), bits(&one), "F = {}", f[l]);
            }
            let gram: [Mat3; LANES] = std::array::from_fn(|l| f[l] * f[l].transpose());
            let eigen = sym_eigen3_lanes(&gram);
            for l in 0..LANES {
                assert_eq!(eigen[l], sym_eigen3(&gram[l]));
            }
        }
    }

    #[test]
    fn lanes_pass_non_finite_input_through_like_the_scalar_solver() {
        let f = [
            Mat3::from_element(f64::NAN),
            Mat3::identity() * 2.0,
            Mat3::from_element(f64::INFINITY),
            Mat3::zeros(),
        ];
        let batch = svd_rv_lanes(&f);
        for l in 0..LANES {
            let one = svd_rv(&f[l]);
            let same = |a: f64, b: f64| a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan());
            assert!(
                batch[l]
                    .u
                    .iter()
                    .zip(one.u.iter())
                    .all(|(a, b)| same(*a, *b))
            );
            assert!(
                batch[l]
                    .v
                    .iter()
                    .zip(one.v.iter())
                    .all(|(a, b)| same(*a, *b))
            );
        }
    }
}
