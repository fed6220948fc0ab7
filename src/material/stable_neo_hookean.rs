//! Stable Neo-Hookean (Smith, de Goes, Kim 2018, "Stable Neo-Hookean Flesh Simulation", ACM TOG
//! 37(2)), the rest-stable form with the log term (their §3):
//! `Ψ = μ′/2 (I_C − 3) + λ′/2 (J − α)² − μ′/2 log(I_C + 1)`, `I_C = tr(FᵀF)`, `J = det F`,
//! `P = μ′(1 − 1/(I_C + 1)) F + λ′(J − α) cof F`, `cof F = ∂J/∂F = J F⁻ᵀ`.
//!
//! Parameters: `α = 1 + 3μ′/(4λ′)` makes the rest state stress-free, and the paper's Lamé
//! reparametrisation `μ′ = 4μ/3`, `λ′ = λ + 5μ/6` makes the small-strain limit the linear
//! elasticity of the user's (μ, λ) (checked by the uniaxial test's Young's modulus), so that
//! `α = 1 + μ/λ′`. One deviation: we subtract the constant `Ψ(I) = λ′/2 (1 − α)² − μ′/2 log 4`
//! so that the rest state has zero energy like every other model (P and dP are unchanged).
//! HOBAK drops the log term; we keep it.
//!
//! In principal stretches, with `I = Σσₖ²`, `J = σ₁σ₂σ₃`, `cₖ = ∂J/∂σₖ` (the product of the other
//! two) and `a = μ′(1 − 1/(I + 1))`: `Ψ̂ = μ′/2 (I − 3) + λ′/2 (J − α)² − μ′/2 log(I + 1)`,
//! `pₖ = a σₖ + λ′(J − α) cₖ`. The pair eigenvalues are `a ∓ λ′(J − α) σₘ` (m the third index),
//! closed forms with no division. Everything is a polynomial or log(I + 1) ≥ 0 in σ, so Ψ̂, p and
//! ∂p/∂σ are finite for inverted and flat F with no extension; an inverted J < 0 is pushed back
//! by the volume term. F = 0 exactly is a critical point (every gradient term vanishes there):
//! a tet collapsed to a single point feels no force, though any perturbation leaves it.
//!
//! The paper's eigenanalysis (§4) gives the six twist and flip eigenvalues in closed form (the
//! pair eigenvalues above) but leaves the 3×3 scaling block (off-diagonal entries
//! `λ′(2J − α)σₘ + 2μ′σₖσₗ/(I + 1)²`) to a numerical eigensolver; `analytic` does the same here.

use super::Lame;
use super::isotropic::Isotropic;
use crate::math::{Mat3, Vec3};

/// Stable Neo-Hookean in principal stretches (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StableNeoHookean {
    /// The user's Lamé parameters (the small-strain behaviour).
    pub lame: Lame,
    /// μ′ = 4μ/3, Pa: the energy's shear coefficient.
    pub mu: f64,
    /// λ′ = λ + 5μ/6, Pa: the energy's volume coefficient.
    pub lambda: f64,
    /// α = 1 + 3μ′/(4λ′) = 1 + μ/λ′, the rest-stable target of J.
    pub alpha: f64,
    /// The paper's energy at rest, subtracted so that Ψ(I) = 0.
    rest_energy: f64,
}

impl StableNeoHookean {
    /// From the Lamé parameters of the small-strain limit.
    pub fn new(lame: Lame) -> Self {
        let mu = 4.0 * lame.mu / 3.0;
        let lambda = lame.lambda + 5.0 * lame.mu / 6.0;
        let alpha = 1.0 + 0.75 * mu / lambda;
        StableNeoHookean {
            lame,
            mu,
            lambda,
            alpha,
            rest_energy: 0.5 * lambda * (1.0 - alpha) * (1.0 - alpha) - 0.5 * mu * 4f64.ln(),
        }
    }

    /// `(a, λ′(J − α), I)` at σ: the coefficients of σₖ and cₖ in pₖ, and I = Σσₖ².
    fn coefficients(&self, s: &Vec3) -> (f64, f64, f64) {
        let i = s.norm_squared();
        let a = self.mu * (1.0 - 1.0 / (i + 1.0));
        (a, self.lambda * (s.product() - self.alpha), i)
    }
}

/// `cₖ = ∂(σ₁σ₂σ₃)/∂σₖ`, the product of the other two stretches.
pub(crate) fn cofactors(s: &Vec3) -> Vec3 {
    Vec3::new(s[1] * s[2], s[0] * s[2], s[0] * s[1])
}

impl Isotropic for StableNeoHookean {
    fn psi(&self, s: &Vec3) -> f64 {
        let i = s.norm_squared();
        let d = s.product() - self.alpha;
        0.5 * self.mu * (i - 3.0) + 0.5 * self.lambda * d * d
            - 0.5 * self.mu * (i + 1.0).ln()
            - self.rest_energy
    }

    fn dpsi(&self, s: &Vec3) -> Vec3 {
        let (a, b, _) = self.coefficients(s);
        a * s + b * cofactors(s)
    }

    fn d2psi(&self, s: &Vec3) -> Mat3 {
        let (a, b, i) = self.coefficients(s);
        let c = cofactors(s);
        let q = 2.0 * self.mu / ((i + 1.0) * (i + 1.0));
        let mut h = q * s * s.transpose() + self.lambda * c * c.transpose();
        for k in 0..3 {
            h[(k, k)] += a;
        }
        // ∂²J/∂σₖ∂σₗ = σₘ off the diagonal.
        for (k, l, m) in [(0, 1, 2), (0, 2, 1), (1, 2, 0)] {
            h[(k, l)] += b * s[m];
            h[(l, k)] += b * s[m];
        }
        h
    }

    /// `(a − λ′(J − α)σₘ, a + λ′(J − α)σₘ)`.
    fn pair_eigenvalues(&self, s: &Vec3, _: &Vec3, _: &Mat3, i: usize, j: usize) -> (f64, f64) {
        let (a, b, _) = self.coefficients(s);
        let m = 3 - i - j;
        (a - b * s[m], a + b * s[m])
    }
}
