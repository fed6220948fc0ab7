//! Neo-Hookean, SPEC §2: `Ψ = μ/2 (tr(FᵀF) − 3) − μ log J + λ/2 (log J)²`,
//! `P = μ(F − F⁻ᵀ) + λ log J F⁻ᵀ`.
//!
//! In principal stretches, with `L = Σ ln σₖ = log J`:
//! `Ψ̂(σ) = μ/2 (Σσₖ² − 3) − μL + λ/2 L²`, `pₖ = ∂Ψ̂/∂σₖ = μσₖ + (λL − μ)/σₖ`.
//!
//! **Below the inversion threshold** ε (default [`DEFAULT_INVERSION_THRESHOLD`] = 0.1, 90 %
//! compression along one axis) each ln σₖ is replaced by its second-order Taylor expansion at ε
//! ([`ExtendedLog`]): `ℓ(σ) = ln ε + d − d²/2`, `d = (σ − ε)/ε`, so that ℓ′ = (2ε − σ)/ε² is
//! Irving et al. 2004's linear extrapolation of 1/σ. `L = Σ ℓ(σₖ)` then falls without bound
//! (quadratically) as a stretch is crushed through zero and beyond, and with it the volume
//! term's push `(λL − μ)ℓ′(σₖ)`: the diagonal stress of a crushed stretch keeps growing (∂pₖ/∂σₖ
//! = μ + λℓ′² + (λL − μ)ℓ″ > 0 wherever λL < μ, which holds below ε), so no load of the order
//! of E crushes a Neo-Hookean body flat; at σ = 0 with the other stretches at rest the push is
//! about 76λ (at ε itself 23λ). Where every σₖ ≥ ε the model is exactly the formula.
//!
//! Tangled elements (inverted, or in a body that overlaps itself) are not meant to be handled by
//! this extension: the body evaluates them with [`NeoHookean::recovery`] (Irving's clamp at a
//! stretch of 0.6, see [`super::clamp`] and [`crate::elastic::recovery`]) until they are
//! untangled. `neo-hookean-clamped` is [`NeoHookean::clamped`]: Irving's clamp below ε instead of
//! the extended log.

use super::clamp::{Clamped, StretchClamp};
use super::isotropic::{Derivatives, ExtendedLog, PAIRS, isotropic_from_all};
use super::{DEFAULT_INVERSION_THRESHOLD, Lame};
use crate::math::{Mat3, Vec3};

/// Neo-Hookean in principal stretches (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NeoHookean {
    /// Lamé parameters.
    pub lame: Lame,
    /// The stretch threshold ε below which ln σ is extended.
    pub threshold: f64,
}

impl NeoHookean {
    /// With the default inversion threshold (`neo-hookean`).
    pub fn new(lame: Lame) -> Self {
        Self::with_threshold(lame, DEFAULT_INVERSION_THRESHOLD)
    }

    /// With a given inversion threshold (a stretch in (0, 1)).
    pub fn with_threshold(lame: Lame, threshold: f64) -> Self {
        NeoHookean { lame, threshold }
    }

    /// `neo-hookean-clamped` at the default threshold: the formula above ε, Irving's clamp below
    /// it, with a spring and push matched to the formula at ε ([`StretchClamp::matching`]).
    pub fn clamped(lame: Lame) -> Clamped<Self> {
        Self::clamped_with_threshold(lame, DEFAULT_INVERSION_THRESHOLD)
    }

    /// `neo-hookean-clamped` with the clamp at `threshold`. The wrapped model's own threshold
    /// sits at the clamp's floor, so it is the formula for every stretch the clamp lets through.
    pub fn clamped_with_threshold(lame: Lame, threshold: f64) -> Clamped<Self> {
        Clamped::matching(
            Self::with_threshold(lame, StretchClamp::floor_of(threshold)),
            threshold,
        )
    }

    /// What tangled elements are evaluated with: the clamp at `threshold` (default 0.6) with a
    /// 2μ spring and push, which brings every collapsed, scrambled and inverted start of the
    /// recovery sweep back (see [`super::clamp`]).
    pub fn recovery(lame: Lame, threshold: f64) -> Clamped<Self> {
        let clamp = StretchClamp::with_shear_modulus(threshold, lame.mu);
        Clamped {
            model: Self::with_threshold(lame, clamp.floor()),
            clamp,
        }
    }

    fn log(&self) -> ExtendedLog {
        ExtendedLog {
            eps: self.threshold,
        }
    }

    /// Ψ̂, p, H and the pair eigenvalues at σ, sharing L and the logarithms.
    fn all(&self, s: &Vec3) -> Derivatives {
        let Lame { mu, lambda } = self.lame;
        let log = self.log();
        let l: f64 = s.iter().map(|&x| log.value(x)).sum();
        let c = lambda * l - mu;
        let psi = 0.5 * mu * (s.norm_squared() - 3.0) - mu * l + 0.5 * lambda * l * l;
        let d1 = s.map(|x| log.d1(x));
        let p = mu * s + c * d1;
        let mut h = lambda * d1 * d1.transpose();
        for k in 0..3 {
            h[(k, k)] += mu + c * log.d2(s[k]);
        }
        let mut pair_sym = Vec3::zeros();
        let mut pair_skew = Vec3::zeros();
        for (n, &(a, b)) in PAIRS.iter().enumerate() {
            pair_sym[n] = mu + c * log.d1_divided_difference(s[a], s[b]);
            // Exactly 1/(σₐσ_b) above the threshold; below it the rotation-variant energy has its
            // genuine pole at σₐ = −σ_b, guarded.
            pair_skew[n] = mu + c * log.d1_sum_quotient(s[a], s[b]);
        }
        Derivatives {
            psi,
            p,
            h,
            pair_sym,
            pair_skew,
        }
    }
}

isotropic_from_all!(NeoHookean);
