//! Small dense linear algebra shared by the kernels: the rotation-variant SVD of Irving et al.
//! 2004, a symmetric 3×3 eigensolver, and the PSD clamp of Teran et al. 2005.
//!
//! Both decompositions are hand-written cyclic Jacobi iterations with exact rotations rather than
//! nalgebra's general SVD: nalgebra does not promise sorted singular values or proper rotations
//! (det U = det V = +1), which invertible FEM needs, and a 3×3 Jacobi is faster and equally
//! accurate (nalgebra is the oracle in the tests).

use nalgebra::{Matrix3, Vector3};

mod lanes;
pub use lanes::{LANES, svd_rv_lanes, svd_rv_lanes_into, sym_eigen3_lanes};

/// A 3-vector of f64.
pub type Vec3 = Vector3<f64>;
/// A 3×3 matrix of f64 (column-major, as nalgebra stores it).
pub type Mat3 = Matrix3<f64>;

/// `F = U · diag(σ) · Vᵀ` with U, V proper rotations.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Svd {
    /// Left rotation, det U = +1.
    pub u: Mat3,
    /// Singular values, σ₁ ≥ σ₂ ≥ |σ₃|; σ₃ < 0 exactly when det F < 0.
    pub sigma: Vec3,
    /// Right rotation, det V = +1.
    pub v: Mat3,
}

impl Svd {
    /// `U · diag(σ) · Vᵀ`.
    pub fn compose(&self) -> Mat3 {
        self.u * Mat3::from_diagonal(&self.sigma) * self.v.transpose()
    }
}

/// Sweeps are a safety cap: exact-rotation Jacobi on a 3×3 converges quadratically and stops
/// after 3–5 sweeps at machine precision (3 are not always enough, so we test for convergence).
const MAX_SWEEPS: usize = 12;

/// The Jacobi rotations in the planes (p, r), in sweep order: `pr` indexes entry (p, r) in the
/// off-diagonal triple, `pk` and `rk` the entries coupling p and r to the third index.
const PLANES: [(usize, usize, usize, usize, usize); 3] =
    [(0, 1, 0, 1, 2), (0, 2, 1, 0, 2), (1, 2, 2, 0, 1)];

/// The diagonal, the off-diagonal triple (0,1), (0,2), (1,2), and the convergence tolerance of
/// a symmetric matrix; `None` when it is zero or not finite (nothing to rotate).
#[inline]
fn jacobi_start(a: &Mat3) -> ([f64; 3], [f64; 3], Option<f64>) {
    let d = [a[(0, 0)], a[(1, 1)], a[(2, 2)]];
    let off = [a[(0, 1)], a[(0, 2)], a[(1, 2)]];
    let scale = d
        .iter()
        .chain(off.iter())
        .fold(0.0f64, |m, x| m.max(x.abs()));
    let tolerance = (scale != 0.0 && scale.is_finite()).then_some(f64::EPSILON * 1e-3 * scale);
    (d, off, tolerance)
}

/// The rotation `(t, c, s)` that zeroes `apr` between diagonal entries `dp` and `dr`:
/// t = tan φ, the smaller root of t² + 2θt − 1 = 0 (the smallest rotation), c = cos φ, s = sin φ.
#[inline(always)]
fn jacobi_rotation(dp: f64, dr: f64, apr: f64) -> (f64, f64, f64) {
    let theta = (dr - dp) / (2.0 * apr);
    let t = if theta.is_finite() {
        theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt())
    } else {
        0.0
    };
    let c = 1.0 / (t * t + 1.0).sqrt();
    (t, c, t * c)
}

/// Eigen-decomposition of a symmetric 3×3 matrix `a = Q · diag(λ) · Qᵀ`, eigenvalues sorted in
/// descending order, det Q = +1. The matrix must be symmetric.
pub fn sym_eigen3(a: &Mat3) -> (Vec3, Mat3) {
    // The six distinct entries as scalars: each rotation touches each once.
    let (mut d, mut off, tolerance) = jacobi_start(a);
    let mut q = Mat3::identity();
    let Some(tolerance) = tolerance else {
        return sort_descending(Vec3::from(d), q);
    };
    for _ in 0..MAX_SWEEPS {
        if off[0].abs() + off[1].abs() + off[2].abs() <= tolerance {
            break;
        }
        for (p, r, pr, pk, rk) in PLANES {
            let apr = off[pr];
            if apr == 0.0 {
                continue;
            }
            let (t, c, s) = jacobi_rotation(d[p], d[r], apr);
            d[p] -= t * apr;
            d[r] += t * apr;
            off[pr] = 0.0;
            let (apk, ark) = (off[pk], off[rk]);
            off[pk] = c * apk - s * ark;
            off[rk] = s * apk + c * ark;
            for row in 0..3 {
                let (qp, qr) = (q[(row, p)], q[(row, r)]);
                q[(row, p)] = c * qp - s * qr;
                q[(row, r)] = s * qp + c * qr;
            }
        }
    }
    sort_descending(Vec3::from(d), q)
}

/// Sort eigenpairs by descending eigenvalue and make the eigenvector basis a proper rotation.
fn sort_descending(lambda: Vec3, q: Mat3) -> (Vec3, Mat3) {
    // A stable sort of three by strict compare-and-swap (what `sort_by` gave, without its
    // general machinery, which cost 8 % of the element loop).
    let mut order = [0usize, 1, 2];
    for (a, b) in [(0, 1), (1, 2), (0, 1)] {
        if lambda[order[b]].total_cmp(&lambda[order[a]]).is_gt() {
            order.swap(a, b);
        }
    }
    let mut sorted_q =
        Mat3::from_columns(&[q.column(order[0]), q.column(order[1]), q.column(order[2])]);
    if sorted_q.determinant() < 0.0 {
        sorted_q.set_column(2, &(-sorted_q.column(2)));
    }
    (
        Vec3::new(lambda[order[0]], lambda[order[1]], lambda[order[2]]),
        sorted_q,
    )
}

/// Rotation-variant SVD (Irving et al. 2004, §5): `F = U · diag(σ) · Vᵀ`, det U = det V = +1,
/// σ₁ ≥ σ₂ ≥ |σ₃|, and an inversion (det F < 0) carried by σ₃ < 0.
///
/// V comes from the Jacobi eigenvectors of FᵀF (sorted, det +1); U and σ from a Givens QR of
/// F·V, whose R is diagonal up to rounding. Givens rotations keep U a proper rotation for every F,
/// including rank-0, rank-1 and rank-2 F and repeated singular values, and leave the sign of
/// det F on the last diagonal entry of R. Accuracy is absolute (about 1e-15·‖F‖), which is what
/// forces need.
pub fn svd_rv(f: &Mat3) -> Svd {
    let (_, v) = sym_eigen3(&(f.transpose() * f));
    svd_from_v(f, v)
}

/// The Givens rotations of the QR of F·V, in order: (column, row p, row r), zeroing (r, column).
const GIVENS: [(usize, usize, usize); 3] = [(0, 0, 1), (0, 0, 2), (1, 1, 2)];

/// U and σ from a Givens QR of F·V, given V (the second half of [`svd_rv`]).
#[inline]
fn svd_from_v(f: &Mat3, v: Mat3) -> Svd {
    let mut b = f * v;
    let mut ut = Mat3::identity(); // accumulates Qᵀ = G₃G₂G₁
    for (col, p, r) in GIVENS {
        givens_rows(&mut b, &mut ut, col, p, r);
    }
    let sigma = Vec3::new(b[(0, 0)], b[(1, 1)], b[(2, 2)]);
    let mut u = ut.transpose();
    align_null_pair(&mut u, &v, &sigma);
    Svd { u, sigma, v }
}

/// When σ₂ = σ₃ = 0 (F of rank one or zero), U's last two columns can turn by any angle without
/// changing F, and the choice decides which way the tet's collapsed cross-section reopens. Pick
/// the angle that brings the rotation U·Vᵀ closest to the identity (largest trace), so every tet
/// of a body squeezed onto a line reopens the same, untwisted way instead of by an arbitrary angle
/// of the eigensolver's.
fn align_null_pair(u: &mut Mat3, v: &Mat3, sigma: &Vec3) {
    let tiny = 1e-12 * sigma[0].abs().max(f64::MIN_POSITIVE);
    if sigma[1].abs() > tiny || sigma[2].abs() > tiny {
        return;
    }
    // N = vᵀu on the null pair; tr(G·N) is largest at (cos, sin) ∝ (N₁₁ + N₂₂, N₁₂ − N₂₁).
    let n = |i: usize, j: usize| v.column(i).dot(&u.column(j));
    let (c, s) = (n(1, 1) + n(2, 2), n(1, 2) - n(2, 1));
    let h = (c * c + s * s).sqrt();
    if h == 0.0 {
        return;
    }
    let (c, s) = (c / h, s / h);
    let (u1, u2) = (u.column(1).into_owned(), u.column(2).into_owned());
    // u ← u·G with G = [[c, −s], [s, c]].
    u.set_column(1, &(c * u1 + s * u2));
    u.set_column(2, &(-s * u1 + c * u2));
}

/// Rotate rows p and r of `b` (and of `ut`) so that `b[(r, col)]` becomes zero and
/// `b[(p, col)] = hypot(...) ≥ 0`.
fn givens_rows(b: &mut Mat3, ut: &mut Mat3, col: usize, p: usize, r: usize) {
    let x = b[(p, col)];
    let y = b[(r, col)];
    // sqrt(x² + y²) rather than hypot: F's entries never come near overflow, and hypot is a
    // slow library call.
    let h = (x * x + y * y).sqrt();
    if h == 0.0 {
        return;
    }
    let (c, s) = (x / h, y / h);
    for m in [&mut *b, &mut *ut] {
        for k in 0..3 {
            let mp = m[(p, k)];
            let mr = m[(r, k)];
            m[(p, k)] = c * mp + s * mr;
            m[(r, k)] = -s * mp + c * mr;
        }
    }
    b[(r, col)] = 0.0;
}

/// True when the symmetric 3×3 matrix is positive semi-definite, decided without an eigensolver:
/// a diagonally dominant matrix with a non-negative diagonal is PSD, and otherwise every principal
/// minor (three diagonal entries, three 2×2 minors, the determinant) must be non-negative, which
/// is necessary and sufficient for a symmetric matrix. A matrix whose smallest eigenvalue is
/// negative only at rounding level (|λ| ≲ 1e-15·‖a‖) may pass; that is harmless for CG.
#[inline]
pub fn is_psd3(a: &Mat3) -> bool {
    let (a00, a11, a22) = (a[(0, 0)], a[(1, 1)], a[(2, 2)]);
    let (a01, a02, a12) = (a[(0, 1)], a[(0, 2)], a[(1, 2)]);
    if a00 < 0.0 || a11 < 0.0 || a22 < 0.0 {
        return false;
    }
    if a00 >= a01.abs() + a02.abs() && a11 >= a01.abs() + a12.abs() && a22 >= a02.abs() + a12.abs()
    {
        return true;
    }
    let m01 = a00 * a11 - a01 * a01;
    let m02 = a00 * a22 - a02 * a02;
    let m12 = a11 * a22 - a12 * a12;
    if m01 < 0.0 || m02 < 0.0 || m12 < 0.0 {
        return false;
    }
    // Cofactor expansion along the first row.
    a00 * m12 - a01 * (a01 * a22 - a12 * a02) + a02 * (a01 * a12 - a11 * a02) >= 0.0
}

/// Project a symmetric 3×3 matrix onto the PSD cone by clamping negative eigenvalues to zero.
/// Returns the matrix unchanged (bit for bit) when it is already PSD, so that the projected and
/// exact tangents agree exactly near rest. The bool says whether anything was clamped.
pub fn clamp_psd3(a: &Mat3) -> (Mat3, bool) {
    map_negative_eigenvalues(a, |l| l.max(0.0))
}

/// Make a symmetric 3×3 matrix PSD by replacing its eigenvalues by their absolute values (the
/// `abs` strategy: a negative curvature becomes an equally strong positive one instead of none).
/// Unchanged (bit for bit) when already PSD; the bool says whether anything changed.
pub fn abs_psd3(a: &Mat3) -> (Mat3, bool) {
    map_negative_eigenvalues(a, f64::abs)
}

/// `Q·diag(map(λ))·Qᵀ` from an eigen-decomposition `a = Q·diag(λ)·Qᵀ`, or `a` itself when no
/// eigenvalue is negative. `map` must leave non-negative values unchanged.
pub fn map_eigenvalues(
    a: &Mat3,
    lambda: &Vec3,
    q: &Mat3,
    map: impl Fn(f64) -> f64,
) -> (Mat3, bool) {
    if lambda.min() >= 0.0 {
        return (*a, false);
    }
    let mapped = lambda.map(map);
    (q * Mat3::from_diagonal(&mapped) * q.transpose(), true)
}

fn map_negative_eigenvalues(a: &Mat3, map: impl Fn(f64) -> f64) -> (Mat3, bool) {
    // The cheap exact test first: near rest (the common case) no eigensolver runs at all.
    if is_psd3(a) {
        return (*a, false);
    }
    let (lambda, q) = sym_eigen3(a);
    map_eigenvalues(a, &lambda, &q, map)
}

/// True when every entry is finite.
pub fn all_finite(m: &Mat3) -> bool {
    m.iter().all(|x| x.is_finite())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check_svd(f: &Mat3) {
        let svd = svd_rv(f);
        let scale = f.norm().max(1e-300);
        assert!(
            (svd.compose() - f).norm() <= 1e-13 * scale,
            "F not reproduced: {f}"
        );
        assert!((svd.u.determinant() - 1.0).abs() < 1e-12);
        assert!((svd.v.determinant() - 1.0).abs() < 1e-12);
        assert!((svd.u.transpose() * svd.u - Mat3::identity()).norm() < 1e-13);
        assert!((svd.v.transpose() * svd.v - Mat3::identity()).norm() < 1e-13);
        let s = svd.sigma;
        let tol = 1e-13 * scale;
        assert!(
            s[0] + tol >= s[1] && s[1] + tol >= s[2].abs(),
            "unsorted {s}"
        );
        assert!(s[0] >= 0.0 && s[1] >= 0.0);
        let det = f.determinant();
        if det.abs() > 1e-10 * scale.powi(3) {
            assert_eq!(
                det < 0.0,
                s[2] < 0.0,
                "inversion sign on σ₃: det {det}, σ {s}"
            );
        }
        // The singular values agree with nalgebra's (the oracle) up to order and sign.
        let mut oracle: Vec<f64> = f
            .svd(false, false)
            .singular_values
            .iter()
            .copied()
            .collect();
        oracle.sort_by(|a, b| b.total_cmp(a));
        for k in 0..3 {
            assert!(
                (s[k].abs() - oracle[k]).abs() <= 1e-13 * scale,
                "σ {s} vs {oracle:?}"
            );
        }
    }

    #[test]
    fn svd_special_cases() {
        let r = nalgebra::Rotation3::from_euler_angles(0.3, -1.1, 2.0).into_inner();
        let cases = [
            Mat3::identity(),
            Mat3::zeros(),
            -Mat3::identity(),
            Mat3::from_diagonal(&Vec3::new(1.0, -1.0, 1.0)),
            Mat3::from_diagonal(&Vec3::new(0.5, 2.0, 3.0)),
            Mat3::from_diagonal(&Vec3::new(0.0, 2.0, 0.0)),
            Mat3::from_diagonal(&Vec3::new(2.0, 2.0, 2.0)) * r,
            r * Mat3::from_diagonal(&Vec3::new(1.0, 1.0, 0.0)),
            r * Mat3::from_diagonal(&Vec3::new(1.0, 1.0, -1e-9)),
            Vec3::new(1.0, 2.0, 3.0) * Vec3::new(-1.0, 0.5, 0.25).transpose(),
            Mat3::new(1.0, 1e-8, 0.0, 0.0, 1.0, 1e-8, 0.0, 0.0, 1.0),
        ];
        for f in &cases {
            check_svd(f);
        }
    }

    #[test]
    fn svd_random() {
        let mut state = 12345u64;
        let mut next = move || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((state >> 11) as f64 / (1u64 << 53) as f64) * 4.0 - 2.0
        };
        for _ in 0..2000 {
            let f = Mat3::from_fn(|_, _| next());
            check_svd(&f);
        }
    }

    #[test]
    fn psd_test_by_minors_agrees_with_eigenvalues() {
        let mut state = 777u64;
        let mut next = move || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((state >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
        };
        let (mut psd, mut indefinite) = (0, 0);
        for _ in 0..5000 {
            let b = Mat3::from_fn(|_, _| next());
            // Symmetric, shifted so that about half are PSD; some rank-deficient ones too.
            let a = b * b.transpose() - Mat3::from_diagonal_element(0.3 * (next() + 1.0));
            let (l, _) = sym_eigen3(&a);
            if l.min().abs() < 1e-12 {
                continue;
            }
            assert_eq!(is_psd3(&a), l.min() >= 0.0, "{a} with eigenvalues {l}");
            if l.min() >= 0.0 {
                psd += 1;
            } else {
                indefinite += 1;
            }
        }
        assert!(psd > 500 && indefinite > 500, "{psd} {indefinite}");
        let rank_one = Vec3::new(1.0, 2.0, -3.0) * Vec3::new(1.0, 2.0, -3.0).transpose();
        assert!(is_psd3(&rank_one) && is_psd3(&Mat3::zeros()));
        assert!(!is_psd3(&-rank_one));
    }

    #[test]
    fn abs_flips_negative_eigenvalues() {
        let b = Mat3::new(1.0, 2.0, 0.0, 2.0, 1.0, 0.0, 0.0, 0.0, -1.0);
        let (c, changed) = abs_psd3(&b);
        assert!(changed);
        let (l, _) = sym_eigen3(&c);
        assert!((l - Vec3::new(3.0, 1.0, 1.0)).norm() < 1e-13, "{l}");
        let a = Mat3::new(2.0, 0.5, 0.0, 0.5, 1.0, 0.1, 0.0, 0.1, 3.0);
        assert_eq!(abs_psd3(&a), (a, false));
    }

    #[test]
    fn clamp_keeps_psd_and_fixes_indefinite() {
        let a = Mat3::new(2.0, 0.5, 0.0, 0.5, 1.0, 0.1, 0.0, 0.1, 3.0);
        assert_eq!(clamp_psd3(&a), (a, false));
        let b = Mat3::new(1.0, 2.0, 0.0, 2.0, 1.0, 0.0, 0.0, 0.0, -1.0);
        let (c, clamped) = clamp_psd3(&b);
        assert!(clamped);
        let (l, _) = sym_eigen3(&c);
        assert!(l.min() > -1e-14, "{l}");
        // The positive eigenpair (3, [1,1,0]/√2) survives.
        let e = Vec3::new(1.0, 1.0, 0.0).normalize();
        assert!(((c * e) - 3.0 * e).norm() < 1e-13);
    }
}
