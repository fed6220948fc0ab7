//! St. Venant-Kirchhoff: `Ψ = μ E:E + λ/2 tr(E)²` with the Green strain `E = (FᵀF − I)/2`,
//! `P = F·S`, `S = 2μE + λ tr(E) I` (e.g. Sifakis & Barbič 2012, "FEM simulation of 3D deformable
//! solids", SIGGRAPH course notes).
//!
//! In principal stretches, with `eₖ = (σₖ² − 1)/2` and `T = Σeₖ`: `Ψ̂ = μ Σeₖ² + λ/2 T²`,
//! `pₖ = σₖ(2μeₖ + λT)`, `∂²Ψ̂/∂σ² = diag(2μeₖ + λT + 2μσₖ²) + λσσᵀ`; the pair eigenvalues are
//! `μ(σᵢ² ± σᵢσⱼ + σⱼ² − 1) + λT`, polynomials with no division.
//!
//! Its weakness under compression, kept on purpose (this is the textbook model, used to compare):
//! - it resists compression less and less: under uniaxial stress `P₁₁ = E λ₁(λ₁² − 1)/2`, whose
//!   magnitude peaks at `λ₁ = 1/√3` and falls to zero at `λ₁ = 0`, so a strongly compressed
//!   element softens and then collapses (discussed by Irving et al. 2004 and Teran et al. 2005);
//! - Ψ depends on F only through FᵀF, so a reflected F (`FᵀF = I`, `det F = −1`) has zero energy
//!   and zero stress: an inverted element is not pushed back and may stay inverted, and F = 0
//!   (a tet collapsed to a point) is a stress-free critical point as well.
//!
//! The 3×3 block is a diagonal plus a rank-one term with no simple closed-form eigensystem, so
//! the `analytic` strategy uses the eigensolver here.

use super::Lame;
use super::isotropic::Isotropic;
use crate::math::{Mat3, Vec3};

/// St. Venant-Kirchhoff in principal stretches (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StVenantKirchhoff {
    /// Lamé parameters.
    pub lame: Lame,
}

impl StVenantKirchhoff {
    /// From Lamé parameters.
    pub fn new(lame: Lame) -> Self {
        StVenantKirchhoff { lame }
    }

    /// The principal Green strains eₖ and their sum T.
    fn strains(s: &Vec3) -> (Vec3, f64) {
        let e = s.map(|x| 0.5 * (x * x - 1.0));
        (e, e.sum())
    }
}

impl Isotropic for StVenantKirchhoff {
    fn psi(&self, s: &Vec3) -> f64 {
        let Lame { mu, lambda } = self.lame;
        let (e, t) = Self::strains(s);
        mu * e.norm_squared() + 0.5 * lambda * t * t
    }

    fn dpsi(&self, s: &Vec3) -> Vec3 {
        let Lame { mu, lambda } = self.lame;
        let (e, t) = Self::strains(s);
        s.component_mul(&(2.0 * mu * e).add_scalar(lambda * t))
    }

    fn d2psi(&self, s: &Vec3) -> Mat3 {
        let Lame { mu, lambda } = self.lame;
        let (e, t) = Self::strains(s);
        let mut h = lambda * s * s.transpose();
        for k in 0..3 {
            h[(k, k)] += 2.0 * mu * (e[k] + s[k] * s[k]) + lambda * t;
        }
        h
    }

    /// `μ(σᵢ² + σᵢσⱼ + σⱼ² − 1) + λT` and `μ(σᵢ² − σᵢσⱼ + σⱼ² − 1) + λT`.
    fn pair_eigenvalues(&self, s: &Vec3, _: &Vec3, _: &Mat3, i: usize, j: usize) -> (f64, f64) {
        let Lame { mu, lambda } = self.lame;
        let (_, t) = Self::strains(s);
        let base = mu * (s[i] * s[i] + s[j] * s[j] - 1.0) + lambda * t;
        let cross = mu * s[i] * s[j];
        (base + cross, base - cross)
    }
}
