//! Neo-Hookean, SPEC §2: `Ψ = μ/2 (tr(FᵀF) − 3) − μ log J + λ/2 (log J)²`,
//! `P = μ(F − F⁻ᵀ) + λ log J F⁻ᵀ`.
//!
//! In principal stretches, with `L = Σ ℓ(σₖ)` standing in for log J:
//! `Ψ̂ = μ/2 (Σσₖ² − 3) − μL + λ/2 L²`, `pₖ = μσₖ + (λL − μ) ℓ'(σₖ)`.
//!
//! Irving et al. 2004 (§5) extend the stress below a threshold stretch so that inverted and flat
//! elements have finite forces that push them back. We extend the *energy* instead, through
//! ℓ = [`ExtendedLog`] (ln above the threshold, its quadratic Taylor expansion below), so that
//! Ψ̂, p and ∂p/∂σ stay exact derivatives of each other for every σ, including σ ≤ 0. Above the
//! threshold in every stretch the model is exactly the analytic one.

use super::Lame;
use super::isotropic::{Derivatives, ExtendedLog, Isotropic, PAIRS};
use crate::math::{Mat3, Vec3};

/// Default inversion threshold: stretches below 0.3 (compression to under 30 % along a principal
/// axis) use the extension. Smaller thresholds keep the analytic model longer but make the
/// extension stiffer (ℓ' ~ 1/ε² below it), which slows Newton on badly inverted starts.
pub const DEFAULT_INVERSION_THRESHOLD: f64 = 0.3;

/// Neo-Hookean in principal stretches (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NeoHookean {
    /// Lamé parameters.
    pub lame: Lame,
    /// The extended log J.
    pub log: ExtendedLog,
}

impl NeoHookean {
    /// With the default inversion threshold.
    pub fn new(lame: Lame) -> Self {
        Self::with_threshold(lame, DEFAULT_INVERSION_THRESHOLD)
    }

    /// With a given inversion threshold (a stretch in (0, 1)).
    pub fn with_threshold(lame: Lame, threshold: f64) -> Self {
        NeoHookean {
            lame,
            log: ExtendedLog { eps: threshold },
        }
    }

    fn log_j(&self, s: &Vec3) -> f64 {
        s.iter().map(|&x| self.log.value(x)).sum()
    }

    /// `c = λL − μ`, the coefficient of ℓ'(σₖ) in pₖ.
    fn coefficient(&self, log_j: f64) -> f64 {
        self.lame.lambda * log_j - self.lame.mu
    }

    fn psi_at(&self, s: &Vec3, l: f64) -> f64 {
        let Lame { mu, lambda } = self.lame;
        0.5 * mu * (s.norm_squared() - 3.0) - mu * l + 0.5 * lambda * l * l
    }

    fn dpsi_at(&self, s: &Vec3, c: f64) -> Vec3 {
        let mu = self.lame.mu;
        s.map(|x| mu * x + c * self.log.d1(x))
    }

    fn d2psi_at(&self, s: &Vec3, c: f64) -> Mat3 {
        let Lame { mu, lambda } = self.lame;
        let g = s.map(|x| self.log.d1(x));
        let mut h = lambda * g * g.transpose();
        for k in 0..3 {
            h[(k, k)] += mu + c * self.log.d2(s[k]);
        }
        h
    }

    fn pair_at(&self, s: &Vec3, c: f64, i: usize, j: usize) -> (f64, f64) {
        let mu = self.lame.mu;
        (
            mu + c * self.log.d1_divided_difference(s[i], s[j]),
            mu + c * self.log.d1_sum_quotient(s[i], s[j]),
        )
    }
}

impl Isotropic for NeoHookean {
    fn psi(&self, s: &Vec3) -> f64 {
        self.psi_at(s, self.log_j(s))
    }

    fn dpsi(&self, s: &Vec3) -> Vec3 {
        self.dpsi_at(s, self.coefficient(self.log_j(s)))
    }

    fn d2psi(&self, s: &Vec3) -> Mat3 {
        self.d2psi_at(s, self.coefficient(self.log_j(s)))
    }

    fn pair_eigenvalues(&self, s: &Vec3, _: &Vec3, _: &Mat3, i: usize, j: usize) -> (f64, f64) {
        self.pair_at(s, self.coefficient(self.log_j(s)), i, j)
    }

    /// The same as the separate methods with log J computed once (three logarithms, not 18).
    fn derivatives(&self, s: &Vec3) -> Derivatives {
        let l = self.log_j(s);
        let c = self.coefficient(l);
        let mut pair_sym = Vec3::zeros();
        let mut pair_skew = Vec3::zeros();
        for (k, &(i, j)) in PAIRS.iter().enumerate() {
            (pair_sym[k], pair_skew[k]) = self.pair_at(s, c, i, j);
        }
        Derivatives {
            psi: self.psi_at(s, l),
            p: self.dpsi_at(s, c),
            h: self.d2psi_at(s, c),
            pair_sym,
            pair_skew,
        }
    }
}
