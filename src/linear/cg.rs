//! Preconditioned conjugate gradient for `A·x = b` with A symmetric positive definite, knowing
//! nothing of FEM: A is any [`LinearOperator`] on vertex vectors, constrained (Dirichlet) degrees
//! of freedom are projected out with a 0/1 mask.
//!
//! Hitting the iteration cap is not an error (inexact Newton lives with it): it comes back as
//! `CgInfo { converged: false }`. Errors are reserved for breakdown, `pᵀAp ≤ 0` or a non-finite
//! value, which CG cannot survive; they carry the iteration and leave the best iterate so far in
//! `x`. This departs from faer, whose matrix-free CG errors on hitting the cap.
//!
//! Dot products are summed over fixed-size chunks in order, so results are bit-identical for
//! any number of threads; no allocation happens inside the loop (the workspace holds it all).

use rayon::prelude::*;

use crate::math::{Mat3, Vec3};

/// Entries per parallel chunk of the vector kernels; fixed so reductions are deterministic.
pub(crate) const CHUNK: usize = 2048;

/// A linear operator on vertex vectors (3 DOFs per vertex).
pub trait LinearOperator {
    /// Number of vertices.
    fn len(&self) -> usize;
    /// True when the operator acts on no vertices.
    fn is_empty(&self) -> bool {
        self.len() == 0
    }
    /// `out = A·p`. Takes `&mut self` so that operators may use internal scratch.
    fn apply(&mut self, p: &[Vec3], out: &mut [Vec3]);
}

/// An approximation of A⁻¹, applied as `z = M⁻¹·r`.
pub trait Preconditioner {
    /// `z = M⁻¹·r`. Takes `&mut self`, like [`LinearOperator::apply`], so that preconditioners
    /// may keep their work vectors inside (multigrid) and allocate nothing per application.
    fn apply(&mut self, r: &[Vec3], z: &mut [Vec3]);
}

/// CG stopping rules.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CgParams {
    /// Stop when ‖r‖ ≤ tolerance·‖b‖ (over free DOFs). Default 1e-6.
    pub tolerance: f64,
    /// Iteration cap; reaching it returns `converged: false`. Default 2000.
    pub max_iterations: usize,
}

impl Default for CgParams {
    fn default() -> Self {
        CgParams {
            tolerance: 1e-6,
            max_iterations: 2000,
        }
    }
}

/// What a CG solve did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CgInfo {
    /// Iterations (operator applications after the first residual).
    pub iterations: usize,
    /// Final ‖r‖/‖b‖.
    pub relative_residual: f64,
    /// Whether the tolerance was met.
    pub converged: bool,
}

/// Why CG stopped early. The best iterate so far is left in `x`.
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
pub enum CgError {
    /// `pᵀAp ≤ 0`: A is not positive definite along p (an exact, indefinite tangent).
    #[error(
        "CG breakdown at iteration {iteration}: the system matrix is not positive definite (pᵀAp = {curvature:e})"
    )]
    NotPositiveDefinite {
        /// The iteration at which it happened.
        iteration: usize,
        /// The offending pᵀAp.
        curvature: f64,
        /// Iterations done.
        info: CgInfo,
    },
    /// A NaN or infinity appeared.
    #[error("CG produced a non-finite value at iteration {iteration}")]
    NonFinite {
        /// The iteration at which it happened.
        iteration: usize,
        /// Iterations done.
        info: CgInfo,
    },
}

/// Preallocated CG vectors, reused across solves.
#[derive(Clone, Debug, Default)]
pub struct CgWorkspace {
    r: Vec<Vec3>,
    z: Vec<Vec3>,
    p: Vec<Vec3>,
    ap: Vec<Vec3>,
    partials: Vec<f64>,
}

impl CgWorkspace {
    /// Bytes held.
    pub fn heap_bytes(&self) -> usize {
        use crate::memory::vec_bytes;
        vec_bytes(&self.r)
            + vec_bytes(&self.z)
            + vec_bytes(&self.p)
            + vec_bytes(&self.ap)
            + vec_bytes(&self.partials)
    }

    /// Buffers for `n` vertices.
    pub fn new(n: usize) -> Self {
        let mut ws = CgWorkspace::default();
        ws.resize(n);
        ws
    }

    fn resize(&mut self, n: usize) {
        for v in [&mut self.r, &mut self.z, &mut self.p, &mut self.ap] {
            v.resize(n, Vec3::zeros());
        }
        self.partials.resize(n.div_ceil(CHUNK).max(1), 0.0);
    }
}

/// Deterministic parallel `Σ a·b` (chunk partials summed in order).
pub fn dot(a: &[Vec3], b: &[Vec3], partials: &mut [f64]) -> f64 {
    a.par_chunks(CHUNK)
        .zip(b.par_chunks(CHUNK))
        .zip(partials.par_iter_mut())
        .for_each(|((a, b), s)| *s = a.iter().zip(b).map(|(x, y)| x.dot(y)).sum());
    partials[..a.len().div_ceil(CHUNK)].iter().sum()
}

/// Zero the constrained components: `v ∘ mask`, mask entries 1 (free) or 0 (fixed).
pub fn project(v: &mut [Vec3], free: &[Vec3]) {
    v.par_chunks_mut(CHUNK)
        .zip(free.par_chunks(CHUNK))
        .for_each(|(v, m)| {
            v.iter_mut()
                .zip(m)
                .for_each(|(x, m)| *x = x.component_mul(m))
        });
}

/// Solve `A·x = b` on the free DOFs (`free` is a 0/1 mask per component), starting from the `x`
/// given (its fixed components are kept as they are, normally zero). See the module docs.
pub fn conjugate_gradient(
    a: &mut dyn LinearOperator,
    m: &mut dyn Preconditioner,
    b: &[Vec3],
    x: &mut [Vec3],
    free: &[Vec3],
    params: &CgParams,
    ws: &mut CgWorkspace,
) -> Result<CgInfo, CgError> {
    let n = a.len();
    assert!(b.len() == n && x.len() == n && free.len() == n);
    ws.resize(n);
    let CgWorkspace {
        r,
        z,
        p,
        ap,
        partials,
    } = ws;

    project(x, free);
    a.apply(x, ap);
    r.par_iter_mut()
        .zip(b.par_iter())
        .zip(ap.par_iter())
        .with_min_len(CHUNK)
        .for_each(|((r, b), ap)| *r = b - ap);
    project(r, free);
    let mut bb = masked_norm2(b, free, partials);
    if bb == 0.0 {
        bb = 1.0;
    }
    let b_norm = bb.sqrt();
    let mut info = CgInfo {
        iterations: 0,
        relative_residual: dot(r, r, partials).sqrt() / b_norm,
        converged: false,
    };
    if info.relative_residual <= params.tolerance {
        info.converged = true;
        return Ok(info);
    }
    m.apply(r, z);
    project(z, free);
    p.copy_from_slice(z);
    let mut rz = dot(r, z, partials);

    for iteration in 1..=params.max_iterations {
        a.apply(p, ap);
        project(ap, free);
        let curvature = dot(p, ap, partials);
        if !curvature.is_finite() {
            return Err(CgError::NonFinite { iteration, info });
        }
        if curvature <= 0.0 {
            return Err(CgError::NotPositiveDefinite {
                iteration,
                curvature,
                info,
            });
        }
        let alpha = rz / curvature;
        x.par_iter_mut()
            .zip(r.par_iter_mut())
            .zip(p.par_iter().zip(ap.par_iter()))
            .with_min_len(CHUNK)
            .for_each(|((x, r), (p, ap))| {
                *x += alpha * p;
                *r -= alpha * ap;
            });
        info.iterations = iteration;
        info.relative_residual = dot(r, r, partials).sqrt() / b_norm;
        if !info.relative_residual.is_finite() {
            return Err(CgError::NonFinite { iteration, info });
        }
        if info.relative_residual <= params.tolerance {
            info.converged = true;
            return Ok(info);
        }
        m.apply(r, z);
        project(z, free);
        let rz_next = dot(r, z, partials);
        let beta = rz_next / rz;
        rz = rz_next;
        p.par_iter_mut()
            .zip(z.par_iter())
            .with_min_len(CHUNK)
            .for_each(|(p, z)| *p = z + beta * *p);
    }
    Ok(info)
}

/// ‖b ∘ free‖², deterministic and allocation-free.
fn masked_norm2(b: &[Vec3], free: &[Vec3], partials: &mut [f64]) -> f64 {
    b.par_chunks(CHUNK)
        .zip(free.par_chunks(CHUNK))
        .zip(partials.par_iter_mut())
        .for_each(|((b, m), s)| {
            *s = b
                .iter()
                .zip(m)
                .map(|(b, m)| b.component_mul(m).norm_squared())
                .sum()
        });
    partials[..b.len().div_ceil(CHUNK)].iter().sum()
}

/// No preconditioning: z = r.
#[derive(Clone, Copy, Debug, Default)]
pub struct Identity;

impl Preconditioner for Identity {
    fn apply(&mut self, r: &[Vec3], z: &mut [Vec3]) {
        z.copy_from_slice(r);
    }
}

/// Jacobi: z = r / diag(A), per component.
#[derive(Clone, Debug, Default)]
pub struct Jacobi {
    /// 1 / diag(A) per vertex and component (0 where the diagonal is not positive).
    pub inverse_diagonal: Vec<Vec3>,
}

impl Jacobi {
    /// From the 3×3 diagonal blocks of A (only their diagonals are used).
    pub fn set_from_blocks(&mut self, blocks: &[Mat3]) {
        self.inverse_diagonal.resize(blocks.len(), Vec3::zeros());
        self.inverse_diagonal
            .par_iter_mut()
            .zip(blocks.par_iter())
            .with_min_len(CHUNK)
            .for_each(|(d, b)| *d = b.diagonal().map(|x| if x > 0.0 { 1.0 / x } else { 0.0 }));
    }
}

impl Preconditioner for Jacobi {
    fn apply(&mut self, r: &[Vec3], z: &mut [Vec3]) {
        z.par_iter_mut()
            .zip(r.par_iter().zip(self.inverse_diagonal.par_iter()))
            .with_min_len(CHUNK)
            .for_each(|(z, (r, d))| *z = r.component_mul(d));
    }
}

/// Block Jacobi: z = (3×3 diagonal block of A)⁻¹·r per vertex.
#[derive(Clone, Debug, Default)]
pub struct BlockJacobi {
    /// Inverse of each vertex's 3×3 diagonal block (diagonal Jacobi where it is singular).
    pub inverse_blocks: Vec<Mat3>,
}

impl BlockJacobi {
    /// From the 3×3 diagonal blocks of A.
    pub fn set_from_blocks(&mut self, blocks: &[Mat3]) {
        self.inverse_blocks.resize(blocks.len(), Mat3::zeros());
        self.inverse_blocks
            .par_iter_mut()
            .zip(blocks.par_iter())
            .with_min_len(CHUNK)
            .for_each(|(inv, b)| {
                *inv = b
                    .try_inverse()
                    .filter(|i| i.iter().all(|x| x.is_finite()))
                    .unwrap_or_else(|| {
                        Mat3::from_diagonal(
                            &b.diagonal().map(|x| if x > 0.0 { 1.0 / x } else { 0.0 }),
                        )
                    })
            });
    }
}

impl Preconditioner for BlockJacobi {
    fn apply(&mut self, r: &[Vec3], z: &mut [Vec3]) {
        z.par_iter_mut()
            .zip(r.par_iter().zip(self.inverse_blocks.par_iter()))
            .with_min_len(CHUNK)
            .for_each(|(z, (r, b))| *z = b * r);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A = tridiagonal (−1, 4, −1) on the flattened 3n vector: SPD.
    struct Tridiagonal(usize);

    impl LinearOperator for Tridiagonal {
        fn len(&self) -> usize {
            self.0
        }
        fn apply(&mut self, p: &[Vec3], out: &mut [Vec3]) {
            let flat: Vec<f64> = p.iter().flat_map(|v| v.iter().copied()).collect();
            let m = flat.len();
            for (i, o) in out.iter_mut().enumerate() {
                for c in 0..3 {
                    let k = 3 * i + c;
                    let mut s = 4.0 * flat[k];
                    if k > 0 {
                        s -= flat[k - 1];
                    }
                    if k + 1 < m {
                        s -= flat[k + 1];
                    }
                    o[c] = s;
                }
            }
        }
    }

    #[test]
    fn solves_spd_system_with_fixed_dofs() {
        let n = 50;
        let mut a = Tridiagonal(n);
        let b: Vec<Vec3> = (0..n).map(|i| Vec3::new(i as f64, 1.0, -2.0)).collect();
        let mut free = vec![Vec3::repeat(1.0); n];
        free[0] = Vec3::new(0.0, 1.0, 1.0);
        let mut x = vec![Vec3::zeros(); n];
        let mut ws = CgWorkspace::new(n);
        let params = CgParams {
            tolerance: 1e-12,
            max_iterations: 500,
        };
        let info =
            conjugate_gradient(&mut a, &mut Identity, &b, &mut x, &free, &params, &mut ws).unwrap();
        assert!(info.converged);
        assert_eq!(x[0].x, 0.0);
        let mut ax = vec![Vec3::zeros(); n];
        a.apply(&x, &mut ax);
        for i in 0..n {
            let r = (b[i] - ax[i]).component_mul(&free[i]);
            assert!(r.norm() < 1e-9, "{i}: {r}");
        }
    }

    /// Negative definite along every direction: CG must report it, not hide it.
    struct Negative;
    impl LinearOperator for Negative {
        fn len(&self) -> usize {
            2
        }
        fn apply(&mut self, p: &[Vec3], out: &mut [Vec3]) {
            out.iter_mut().zip(p).for_each(|(o, p)| *o = -p);
        }
    }

    #[test]
    fn breakdown_is_reported() {
        let b = vec![Vec3::x(), Vec3::y()];
        let mut x = vec![Vec3::zeros(); 2];
        let free = vec![Vec3::repeat(1.0); 2];
        let mut ws = CgWorkspace::new(2);
        let err = conjugate_gradient(
            &mut Negative,
            &mut Identity,
            &b,
            &mut x,
            &free,
            &CgParams::default(),
            &mut ws,
        )
        .unwrap_err();
        assert!(matches!(
            err,
            CgError::NotPositiveDefinite { iteration: 1, .. }
        ));
    }

    #[test]
    fn cap_is_not_an_error() {
        let n = 40;
        let b: Vec<Vec3> = (0..n).map(|i| Vec3::new(1.0, i as f64, 0.5)).collect();
        let mut x = vec![Vec3::zeros(); n];
        let free = vec![Vec3::repeat(1.0); n];
        let mut ws = CgWorkspace::new(n);
        let params = CgParams {
            tolerance: 1e-14,
            max_iterations: 3,
        };
        let info = conjugate_gradient(
            &mut Tridiagonal(n),
            &mut Identity,
            &b,
            &mut x,
            &free,
            &params,
            &mut ws,
        )
        .unwrap();
        assert_eq!(info.iterations, 3);
        assert!(!info.converged);
    }
}
