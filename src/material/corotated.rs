//! Corotated, SPEC §2: with F = RS (R the rotation-variant polar rotation U·Vᵀ),
//! `Ψ = μ‖F − R‖² + λ/2 tr(RᵀF − I)²`, `P = 2μ(F − R) + λ tr(RᵀF − I) R`.
//!
//! In principal stretches, with T = Σσₖ: `Ψ̂ = μ Σ(σₖ − 1)² + λ/2 (T − 3)²`,
//! `pₖ = 2μ(σₖ − 1) + λ(T − 3)`, `∂²Ψ̂/∂σ² = 2μI + λ11ᵀ`. A polynomial in σ, so it is finite for
//! every F with no extension; an inverted σ₃ < 0 is pushed back towards +1.
//!
//! The 3×3 block `2μI + λ11ᵀ` has a closed-form eigensystem (Smith et al. 2019, as for ARAP):
//! `2μ + 3λ` on (1, 1, 1)/√3 and `2μ` twice on its orthogonal complement. It is PSD for every
//! physical (μ, λ) (2μ + 3λ is three times the bulk modulus), so the `analytic` strategy never
//! needs an eigensolver for it.

use super::Lame;
use super::isotropic::{Isotropic, guarded_quotient};
use crate::math::{Mat3, Vec3};

/// Corotated in principal stretches (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Corotated {
    /// Lamé parameters.
    pub lame: Lame,
}

impl Corotated {
    /// From Lamé parameters.
    pub fn new(lame: Lame) -> Self {
        Corotated { lame }
    }
}

impl Isotropic for Corotated {
    fn psi(&self, s: &Vec3) -> f64 {
        let Lame { mu, lambda } = self.lame;
        let t = s.sum() - 3.0;
        mu * s.map(|x| (x - 1.0) * (x - 1.0)).sum() + 0.5 * lambda * t * t
    }

    fn dpsi(&self, s: &Vec3) -> Vec3 {
        let Lame { mu, lambda } = self.lame;
        let t = s.sum() - 3.0;
        s.map(|x| 2.0 * mu * (x - 1.0) + lambda * t)
    }

    fn d2psi(&self, _: &Vec3) -> Mat3 {
        let Lame { mu, lambda } = self.lame;
        Mat3::repeat(lambda) + Mat3::from_diagonal_element(2.0 * mu)
    }

    fn block_eigensystem(&self, _: &Vec3, _: &Mat3) -> Option<(Vec3, Mat3)> {
        Some(block_eigensystem(self.lame.mu, self.lame.lambda))
    }

    /// `(pᵢ − pⱼ)/(σᵢ − σⱼ) = 2μ` exactly; `(pᵢ + pⱼ)/(σᵢ + σⱼ) = 2μ + (2λ(T−3) − 4μ)/(σᵢ + σⱼ)`.
    fn pair_eigenvalues(&self, s: &Vec3, _: &Vec3, _: &Mat3, i: usize, j: usize) -> (f64, f64) {
        let Lame { mu, lambda } = self.lame;
        let t = s.sum() - 3.0;
        (
            2.0 * mu,
            2.0 * mu + guarded_quotient(2.0 * lambda * t - 4.0 * mu, s[i] + s[j]),
        )
    }
}

/// The eigensystem of `2μI + λ11ᵀ`: eigenvalues `(2μ + 3λ, 2μ, 2μ)`, eigenvectors (columns)
/// (1, 1, 1)/√3, (1, −1, 0)/√2, (1, 1, −2)/√6.
pub(crate) fn block_eigensystem(mu: f64, lambda: f64) -> (Vec3, Mat3) {
    let (a, b, c) = (
        1.0 / 3f64.sqrt(),
        std::f64::consts::FRAC_1_SQRT_2,
        1.0 / 6f64.sqrt(),
    );
    let q = Mat3::new(a, b, c, a, -b, c, a, 0.0, -2.0 * c);
    (Vec3::new(2.0 * mu + 3.0 * lambda, 2.0 * mu, 2.0 * mu), q)
}
